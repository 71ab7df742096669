"""docs/python.md's Reference against the module: every name it lists exists with the parameters
and defaults it gives, and every public name of photosite, photosite.presets and photosite.torch
(and every public method and property of their classes) is listed. A renamed keyword, a changed
default or a new function without a line in the docs fails here."""
import ast
import inspect
import os
import pathlib
import re
import subprocess
import sys

import pytest

import photosite as ps
import photosite.presets

from conftest import ROOT

REFERENCE = re.compile(r"^## Reference\n(.*?)^## ", re.S | re.M)
# `ps.name`, `ps.Class.member(args)`, `photosite.torch.Name(args)` in the Reference section.
ENTRY = re.compile(r"`((?:ps|photosite\.torch)\.[A-Za-z_][\w.]*)(?:\(([^`]*)\))?`")


def reference_entries():
    text = (ROOT / "docs" / "python.md").read_text()
    m = REFERENCE.search(text)
    assert m, "docs/python.md has no '## Reference' section"
    entries = {}
    for name, args in ENTRY.findall(m.group(1)):
        entries[name] = args if args or f"`{name}()`" in m.group(1) else None
    return entries


def resolve(dotted):
    """The object a documented name stands for ('ps.Camera.expose' -> photosite.Camera.expose)."""
    head, *rest = dotted.split(".")
    if head == "ps":
        obj = ps
    else:  # photosite.torch...
        pytest.importorskip("torch")
        import photosite.torch as pt
        obj, rest = pt, rest[1:]
    for part in rest:
        obj = inspect.getattr_static(obj, part) if inspect.isclass(obj) else getattr(obj, part)
    return obj


def split_params(text):
    """'a, b=1, c="x", **kw' -> [('a', None), ('b', '1'), ('c', '"x"'), ('**kw', None)] (top-level commas)."""
    out, depth, cur = [], 0, ""
    for ch in text + ",":
        depth += ch in "[({"
        depth -= ch in "])}"
        if ch == "," and depth == 0:
            if cur.strip():
                name, eq, default = cur.strip().partition("=")
                out.append((name.strip(), default.strip() if eq else None))
            cur = ""
        else:
            cur += ch
    return out


def actual_params(obj):
    """(name, default text or None) of a callable, self left out: inspect's signature for Python
    code, the first line of pybind11's docstring for the extension's functions."""
    fn = obj.fget if isinstance(obj, property) else obj
    if isinstance(fn, (staticmethod, classmethod)):
        fn = fn.__func__
    try:
        sig = inspect.signature(fn)
        params = []
        for p in sig.parameters.values():
            if p.name == "self":
                continue
            name = ("**" if p.kind is p.VAR_KEYWORD else "*" if p.kind is p.VAR_POSITIONAL else "") + p.name
            params.append((name, None if p.default is p.empty else repr(p.default)))
        return params
    except (ValueError, TypeError):
        pass
    doc = (fn.__doc__ or "").strip().splitlines()[0]
    m = re.match(r"^\w+\((.*)\)(?: -> .*)?$", doc)
    assert m, f"no signature in the docstring of {obj!r}: {doc!r}"
    params = []
    for name, default in split_params(m.group(1)):
        name = name.split(":")[0].strip()
        if name != "self":
            params.append((name, default))
    return params


def same_default(doc, actual):
    if doc is None or actual is None:
        return doc is None and actual is None
    try:
        return ast.literal_eval(doc) == ast.literal_eval(actual)
    except (ValueError, SyntaxError):
        return doc == actual


def public_names():
    """Every public name a user reaches: photosite.__all__ (presets' functions and the classes'
    public methods and properties included) and photosite.torch.NightTransform."""
    names = set()
    for n in ps.__all__:
        obj = getattr(ps, n)
        if n == "presets":
            names.update(f"ps.presets.{f}" for f in dir(ps.presets)
                         if not f.startswith("_") and inspect.isfunction(getattr(ps.presets, f))
                         and getattr(ps.presets, f).__module__ == ps.presets.__name__)
            continue
        names.add(f"ps.{n}")
        if inspect.isclass(obj):
            names.update(f"ps.{n}.{k}" for k, v in vars(obj).items()
                         if not k.startswith("_") and (callable(v) or isinstance(v, property)))
    try:
        import photosite.torch as pt
    except ImportError:
        return names
    for n in dir(pt):
        obj = getattr(pt, n)
        if not n.startswith("_") and inspect.isclass(obj) and obj.__module__ == pt.__name__:
            names.add(f"photosite.torch.{n}")
            names.update(f"photosite.torch.{n}.{k}" for k, v in vars(obj).items()
                         if (not k.startswith("_") or k == "__call__") and callable(v))
    return names


def test_every_documented_name_exists_with_its_parameters_and_defaults():
    entries = reference_entries()
    assert len(entries) > 30, entries
    for name, args in entries.items():
        obj = resolve(name)
        if args is None:  # a property, a class named alone or a module
            continue
        doc = split_params(args)
        actual = actual_params(obj)
        assert [n for n, _ in doc] == [n for n, _ in actual], \
            f"docs/python.md: {name}({args}) names parameters {[n for n, _ in doc]}, the module {[n for n, _ in actual]}"
        for (n, d), (_, a) in zip(doc, actual):
            assert same_default(d, a), f"docs/python.md: {name}: {n} defaults to {d}, the module's is {a}"


def test_every_public_name_is_documented():
    entries = reference_entries()
    missing = sorted(public_names() - set(entries))
    assert not missing, f"public names missing from docs/python.md's Reference: {missing}"


def test_frame_buffer_cache_keys_are_the_documented_ones():
    """docs/python.md's `ps.frame_buffer_cache()  # {'limit_bytes': ..., ...}` lists the keys the
    call returns, both ways (the comment runs onto the next line)."""
    text = (ROOT / "docs" / "python.md").read_text()
    m = re.search(r"^ps\.frame_buffer_cache\(\)\s+#\s*(\{.*?\})", text, re.S | re.M)
    assert m, "docs/python.md shows no ps.frame_buffer_cache() result"
    documented = set(re.findall(r"'(\w+)':", m.group(1)))
    assert len(documented) >= 5, m.group(1)
    assert documented == set(ps.frame_buffer_cache()), (documented, ps.frame_buffer_cache())
    # The documented settings are the ones a fresh interpreter's import sets (other tests here change
    # them): the stale rule on, the limit 1 GiB or a quarter of the machine's memory if less.
    assert "'free_stale': True" in m.group(1), m.group(1)
    assert "a limit of 1 GiB (a quarter of the machine's memory if that is less)" in " ".join(text.split())
    fresh = subprocess.run([sys.executable, "-c", "import photosite; c = photosite.frame_buffer_cache(); "
                            "print(c['limit_bytes'], c['free_stale'])"],
                           capture_output=True, text=True, check=True,
                           env={**os.environ, "PYTHONPATH": str(pathlib.Path(ps.__file__).parents[1])})
    quarter = os.sysconf("SC_PHYS_PAGES") // 4 * os.sysconf("SC_PAGE_SIZE")
    expected = min(1 << 30, quarter)
    assert fresh.stdout.split() == [str(expected), "True"], fresh.stdout


def test_characterize_quantity_keys_are_the_documented_ones(store):
    """The walk-through's `c["system_gain_dn_per_e"]  # {'measured': ..., ...}` names the keys of
    every quantity of ps.characterize's dict, both ways."""
    text = (ROOT / "docs" / "python.md").read_text()
    m = re.search(r'^c\["system_gain_dn_per_e"\]\s+#\s*(\{.*?\})', text, re.M)
    assert m, "docs/python.md shows no characterize quantity"
    documented = set(re.findall(r"'(\w+)':", m.group(1)))
    assert len(documented) >= 4, m.group(1)
    c = ps.characterize("sony-imx174", roi=16)
    assert documented == set(c["system_gain_dn_per_e"]), (documented, c["system_gain_dn_per_e"])
