// The device store's lock call, replaceable by tests (private: never installed).
#pragma once
#include <atomic>

namespace photosite::detail {

// What DeviceStore::load_or_create calls to lock a preset's folder while it creates a map:
// ::flock by default. A test puts a function here that fails as a file system without file locks
// does (ENOLCK from an NFS mount without a lock daemon, EOPNOTSUPP or ENOSYS from some FUSE and
// network file systems), so the store's real code runs its lock-less path without root or such
// a mount.
using FlockFn = int (*)(int fd, int operation);
extern std::atomic<FlockFn> device_store_flock;

}  // namespace photosite::detail
