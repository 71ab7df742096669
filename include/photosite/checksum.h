// Checksums that tell intact data from damaged: of the device's fixed-pattern maps (verified on
// every load) and of the files a batch run writes (verified before a resumed run skips an item).
//
// XXH3-64 (libxxhash) is what photosite verifies: it reads 32-byte stripes with vector
// instructions, where FNV-1a 64 does one dependent multiply per byte (24 MB of device map: 83 ms
// against 3.4 ms in one run here; docs/benchmarks.md), which every map load and every output
// file's bytes paid for. FNV-1a 64 is still computed where it is an identity (a map's
// photosite/checksum) and read where earlier files recorded only it (maps, batch manifests'
// "fnv" key). Neither is a cryptographic hash: they detect damage and truncation, not tampering.
#pragma once
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

namespace photosite {

enum class ChecksumAlgorithm { Xxh3_64, Fnv1a_64 };

// FNV-1a 64 (Fowler, Noll, Vo) of n bytes, continuing from h (the offset basis to start): the
// one loop behind the FNV-1a checksums, the batch run's parameter-file and group hashes and the
// device seed, whose values are recorded in files and seeds and so must not change.
inline constexpr uint64_t kFnv1a64Basis = 0xcbf29ce484222325ull;
uint64_t fnv1a_64(const void* data, size_t n, uint64_t h = kFnv1a64Basis);

// "xxh3_64" and "fnv1a_64": the names written beside a checksum.
std::string_view checksum_algorithm_name(ChecksumAlgorithm a);
std::optional<ChecksumAlgorithm> checksum_algorithm_from_name(std::string_view name);

// A running checksum over bytes fed in pieces; the same bytes give the same value however they
// are split.
class Checksum {
 public:
  explicit Checksum(ChecksumAlgorithm a);
  ~Checksum();
  Checksum(const Checksum&) = delete;
  Checksum& operator=(const Checksum&) = delete;
  void update(const void* data, size_t n);
  uint64_t value() const;
  std::string hex() const;  // 16 lower-case hex digits

 private:
  ChecksumAlgorithm algorithm_;
  uint64_t fnv_ = 0;
  struct Xxh3;
  std::unique_ptr<Xxh3> xxh3_;
};

// The checksum of a file's bytes, as 16 hex digits; nullopt when it cannot be read.
std::optional<std::string> file_checksum_hex(const std::string& path, ChecksumAlgorithm a);

}  // namespace photosite
