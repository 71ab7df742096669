// The machine's vector level (core/isa_detail.h): the CPU's features, capped by $PHOTOSITE_MAX_ISA.
#include <cstdio>
#include <cstdlib>
#include <string>

#include "core/isa_detail.h"
#include "photosite/environment.h"

namespace photosite::detail {

namespace {
Isa cpu_isa() {
#if defined(__x86_64__) && defined(__GNUC__)
  __builtin_cpu_init();  // may run from another file's static initializer, before libgcc's
  // The AVX2 level is AVX2 with FMA (scene/lanes.cpp's sRGB encode fuses): every AVX2 CPU from
  // Intel's Haswell and AMD's Excavator and Zen on has both.
  if (!__builtin_cpu_supports("avx2") || !__builtin_cpu_supports("fma")) return Isa::scalar;
  const bool avx512 = __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl") &&
                      __builtin_cpu_supports("avx512bw") && __builtin_cpu_supports("avx512dq");
  return avx512 ? Isa::avx512 : Isa::avx2;
#else
  return Isa::scalar;
#endif
}

// The cap from $PHOTOSITE_MAX_ISA (unset: none). Bad input exits 2 with the variable named: the
// first caller is usually a static initialiser, outside any handler of photosite::Error.
Isa isa_cap() {
  const auto e = env::get(env::Var::MaxIsa);
  if (!e) return Isa::avx512;
  if (*e == "scalar") return Isa::scalar;
  if (*e == "avx2") return Isa::avx2;
  if (*e == "avx512") return Isa::avx512;
  std::fprintf(stderr, "photosite: error: %s='%s' is not one of scalar, avx2, avx512\n", env::name(env::Var::MaxIsa),
               e->c_str());
  std::exit(2);
}
}  // namespace

Isa machine_isa() {
  static const Isa isa = [] {
    const Isa cpu = cpu_isa(), cap = isa_cap();
    return static_cast<int>(cap) < static_cast<int>(cpu) ? cap : cpu;
  }();
  return isa;
}

}  // namespace photosite::detail
