#include "photosite/checksum.h"

#include <fcntl.h>
#include <unistd.h>
#include <xxhash.h>

#include <cerrno>
#include <vector>

#include <fmt/format.h>

namespace photosite {

uint64_t fnv1a_64(const void* data, size_t n, uint64_t h) {
  // One multiply per byte, each waiting on the last: why XXH3-64 is what loads verify.
  constexpr uint64_t kFnvPrime = 0x100000001b3ull;  // the 64-bit FNV prime
  const auto* p = static_cast<const unsigned char*>(data);
  for (size_t i = 0; i < n; ++i) {
    h ^= p[i];
    h *= kFnvPrime;
  }
  return h;
}

std::string_view checksum_algorithm_name(ChecksumAlgorithm a) {
  switch (a) {
    case ChecksumAlgorithm::Xxh3_64: return "xxh3_64";
    case ChecksumAlgorithm::Fnv1a_64: return "fnv1a_64";
  }
  return "?";
}

std::optional<ChecksumAlgorithm> checksum_algorithm_from_name(std::string_view name) {
  for (ChecksumAlgorithm a : {ChecksumAlgorithm::Xxh3_64, ChecksumAlgorithm::Fnv1a_64})
    if (checksum_algorithm_name(a) == name) return a;
  return std::nullopt;
}

struct Checksum::Xxh3 {
  XXH3_state_t* state = XXH3_createState();
  ~Xxh3() { XXH3_freeState(state); }
};

Checksum::Checksum(ChecksumAlgorithm a) : algorithm_(a), fnv_(kFnv1a64Basis) {
  if (a == ChecksumAlgorithm::Xxh3_64) {
    xxh3_ = std::make_unique<Xxh3>();
    if (!xxh3_->state || XXH3_64bits_reset(xxh3_->state) != XXH_OK) throw std::bad_alloc();
  }
}

Checksum::~Checksum() = default;

void Checksum::update(const void* data, size_t n) {
  if (n == 0) return;
  if (algorithm_ == ChecksumAlgorithm::Xxh3_64) {
    XXH3_64bits_update(xxh3_->state, data, n);
    return;
  }
  fnv_ = fnv1a_64(data, n, fnv_);
}

uint64_t Checksum::value() const {
  return algorithm_ == ChecksumAlgorithm::Xxh3_64 ? XXH3_64bits_digest(xxh3_->state) : fnv_;
}

std::string Checksum::hex() const { return fmt::format("{:016x}", value()); }

std::optional<std::string> file_checksum_hex(const std::string& path, ChecksumAlgorithm a) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return std::nullopt;
  Checksum c(a);
  std::vector<unsigned char> buf(1 << 20);
  bool ok = true;
  for (;;) {
    const ssize_t got = ::read(fd, buf.data(), buf.size());
    if (got < 0 && errno == EINTR) continue;
    if (got < 0) ok = false;
    if (got <= 0) break;
    c.update(buf.data(), static_cast<size_t>(got));
  }
  ::close(fd);
  if (!ok) return std::nullopt;
  return c.hex();
}

}  // namespace photosite
