// The calls atomic_create publishes a finished file with, replaceable by tests (private: never
// installed).
#pragma once
#include <atomic>

namespace photosite::detail {

// What atomic_create (write_exr with create_only: the device store's maps) calls to publish its
// finished temporary without replacing: ::linkat, then, where the file system has no hard links,
// ::renameat2 with RENAME_NOREPLACE. A test puts a function here that fails as such a file
// system does (link: EPERM from FAT/exFAT, EOPNOTSUPP or ENOSYS from some FUSE and network file
// systems; renameat2's flag: EINVAL where the file system cannot honour it), so the real
// publishing code runs its fallbacks without root or such a mount.
using LinkatFn = int (*)(int olddirfd, const char* oldpath, int newdirfd, const char* newpath, int flags);
using Renameat2Fn = int (*)(int olddirfd, const char* oldpath, int newdirfd, const char* newpath, unsigned flags);
extern std::atomic<LinkatFn> publish_linkat;
extern std::atomic<Renameat2Fn> publish_renameat2;

}  // namespace photosite::detail
