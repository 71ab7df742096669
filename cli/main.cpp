// photosite: the command-line front end. Subcommands register themselves (registry.h).
#include <malloc.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iostream>

#include "photosite/environment.h"
#include "photosite/error.h"
#include "photosite/frame_buffers.h"
#include "photosite/io.h"
#include "registry.h"

namespace photosite::cli {
std::vector<std::pair<std::string, SetupFn>>& registry() {
  static std::vector<std::pair<std::string, SetupFn>> r;
  return r;
}
void add_overwrite_flag(CLI::App* sub, bool& overwrite) {
  sub->add_flag("--overwrite,-y", overwrite, "replace an existing output file");
}
std::string flag_for(const std::string& parameter) {
  std::string flag = "--" + parameter;
  std::replace(flag.begin(), flag.end(), '_', '-');
  return flag;
}
std::string message(const std::exception& e) {
  if (const auto* p = dynamic_cast<const ParameterError*>(&e)) return p->message_for(flag_for(p->parameter()));
  return e.what();
}
extern "C" void on_interrupt(int sig) {
  remove_partial_outputs();
  signal(sig, SIG_DFL);
  raise(sig);
}
int exit_status(const std::exception& e) {
  const auto* err = dynamic_cast<const Error*>(&e);
  return err && err->kind() == Error::Kind::BadInput ? 2 : 1;
}
}  // namespace photosite::cli

int main(int argc, char** argv) {
  using namespace photosite;
  // Whole-frame buffers (25 MB for 2048x1024 RGB float) are allocated and freed stage after
  // stage, frame after frame. Serve them from the heap and keep freed memory there, so a buffer
  // freed by one stage is reused by the next instead of being returned to the kernel and
  // page-faulted in again (measured: page faults were a fifth of a night run's time).
  constexpr size_t kMmapThreshold = size_t{32} << 20;  // glibc's upper limit on 64-bit
  mallopt(M_MMAP_THRESHOLD, static_cast<int>(kMmapThreshold));
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
  // One arena for every thread. With one per thread (glibc's default), the buffers that batch's
  // reader and writer threads and the OpenMP workers allocate came from per-thread heaps of at
  // most 64 MiB, mapped and unmapped as frame-size buffers came and went, so they were
  // page-faulted in afresh frame after frame; in the main arena the settings above keep them.
  // Measured (docs/benchmarks.md, "Fifty-third session: frames of other sizes"): `batch` over
  // 4096x2048 frames on the PNG route 0.71-0.81x the wall time with a lower peak, 2048x1024 frames
  // unchanged to 0.93x; the chain's own allocations are few and large, so the one arena's lock is
  // not contended (measured on 2 cores; glibc's per-thread cache serves small allocations without
  // the lock). A user's own setting (MALLOC_ARENA_MAX, or glibc.malloc.arena_max in
  // GLIBC_TUNABLES) is left in force.
  {
    const char* tunables = std::getenv("GLIBC_TUNABLES");
    if (!std::getenv("MALLOC_ARENA_MAX") && !(tunables && std::strstr(tunables, "glibc.malloc.arena_max")))
      mallopt(M_ARENA_MAX, 1);
  }
  // Larger buffers glibc always maps afresh and unmaps when freed (a 4096x2048 frame's RGB float
  // images are 100 MB, its one-channel ones 32 MiB), so each was page-faulted in again at every
  // stage and frame: a fifth of `bench night`'s samples at 4096x2048 were the kernel zeroing pages
  // (docs/benchmarks.md, "Fifty-third session: frames of other sizes"). The library's cache of freed frame
  // buffers (include/photosite/frame_buffers.h) keeps those, up to the limit below; smaller ones
  // stay with the heap as before. The stale rule frees the sizes a run no longer asks for (a run over
  // frames of many sizes) a few frames later; a quarter of the machine's memory caps what is
  // held. (Until the fifty-fourth session the limit was instead capped at 2 GiB, for those stale
  // sizes; at 8192x4096 that cap cost part of the gain: docs/benchmarks.md, "Fifty-fourth session".)
  set_frame_buffer_cache_min_bytes(kMmapThreshold);
  set_frame_buffer_cache_free_stale(true);
  set_frame_buffer_cache_limit(frame_buffer_cache_machine_limit());
  // A file-size limit (ulimit -f) or quota would otherwise kill the process with SIGXFSZ in the
  // middle of a write; ignored, the write fails with EFBIG and is reported as bad input (exit 2)
  // after the temporary file is removed.
  signal(SIGXFSZ, SIG_IGN);
  // Interrupted (Ctrl-C, a scheduler's SIGTERM, a closed terminal): the temporaries of the writes
  // in progress are removed, then the signal takes its default course (batch sets its own
  // handlers, which stop after the items in progress).
  for (int sig : {SIGINT, SIGTERM, SIGHUP}) signal(sig, cli::on_interrupt);
  CLI::App app{"photosite " PHOTOSITE_VERSION
               ": a camera-sensor simulator in physical units, with a day-to-night front end"};
  app.set_version_flag("--version", "photosite " PHOTOSITE_VERSION);
  app.require_subcommand(1);
  auto& reg = cli::registry();
  std::sort(reg.begin(), reg.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  for (auto& [key, setup] : reg) setup(app);
  try {
    check_openmp_threads();  // before any parallel region (include/photosite/environment.h)
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    app.exit(e);
    return 2;  // usage errors are bad input
  } catch (const Error& e) {
    std::fprintf(stderr, "photosite: error: %s\n", cli::message(e).c_str());
    return cli::exit_status(e);
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "photosite: error: out of memory\n");
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "photosite: internal error: %s\n", e.what());
    return 1;
  }
  // What the command printed must have reached its standard output: `presets doc > docs/x.md` on a
  // full disk (or > /dev/full) lost the text and exited 0. As a failed output file, exit 2.
  errno = 0;
  std::cout.flush();  // (synchronised with stdio: an fflush of stdout)
  std::fflush(stdout);
  const int err = errno;
  if (std::ferror(stdout) || !std::cout) {
    std::fprintf(stderr, "photosite: error: writing the standard output failed (%s); what it printed is incomplete\n",
                 err ? std::strerror(err) : "an earlier write failed: a full disk, or a closed output?");
    return 2;
  }
  return 0;
}
