// core/checksum.cpp: the checksums recorded for device maps and batch outputs.
#include <gtest/gtest.h>

#include <cstdint>
#include <fstream>
#include <string>
#include <vector>

#include "photosite/checksum.h"
#include "test_util.h"

using namespace photosite;

namespace {
std::string hex_of(ChecksumAlgorithm a, const std::string& bytes) {
  Checksum c(a);
  c.update(bytes.data(), bytes.size());
  return c.hex();
}
}  // namespace

// Published values: XXH3-64 with seed 0 of the empty input (xxHash's own self-test) and of
// "abc"; FNV-1a 64 of "" (its offset basis) and of "a" (the FNV reference test vectors).
TEST(Checksum, KnownValues) {
  EXPECT_EQ(hex_of(ChecksumAlgorithm::Xxh3_64, ""), "2d06800538d394c2");
  EXPECT_EQ(hex_of(ChecksumAlgorithm::Xxh3_64, "abc"), "78af5f94892f3950");
  EXPECT_EQ(hex_of(ChecksumAlgorithm::Fnv1a_64, ""), "cbf29ce484222325");
  EXPECT_EQ(hex_of(ChecksumAlgorithm::Fnv1a_64, "a"), "af63dc4c8601ec8c");
  for (ChecksumAlgorithm a : {ChecksumAlgorithm::Xxh3_64, ChecksumAlgorithm::Fnv1a_64})
    EXPECT_EQ(checksum_algorithm_from_name(checksum_algorithm_name(a)), a);
  EXPECT_FALSE(checksum_algorithm_from_name("md5"));
}

// However the bytes are split (XXH3 streams through a 256-byte stripe buffer, so pieces of 1,
// 255, 256, 257 bytes and a piece of 1 MiB cross every boundary), the value is the one-shot one,
// and the file's checksum is its bytes' checksum.
TEST(Checksum, PiecesAndFilesGiveTheOneShotValue) {
  std::vector<char> bytes(3 << 20);
  uint32_t x = 12345;
  for (char& b : bytes) b = static_cast<char>((x = x * 1664525u + 1013904223u) >> 24);
  test::TempDir dir;
  const std::string path = (dir.path() / "f.bin").string();
  std::ofstream(path, std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  for (ChecksumAlgorithm a : {ChecksumAlgorithm::Xxh3_64, ChecksumAlgorithm::Fnv1a_64}) {
    const std::string whole = hex_of(a, std::string(bytes.begin(), bytes.end()));
    Checksum c(a);
    size_t at = 0;
    for (size_t piece : {size_t{1}, size_t{255}, size_t{256}, size_t{257}, size_t{1} << 20, size_t{7}}) {
      c.update(bytes.data() + at, piece);
      at += piece;
    }
    c.update(bytes.data() + at, bytes.size() - at);
    EXPECT_EQ(c.hex(), whole) << checksum_algorithm_name(a);
    EXPECT_EQ(file_checksum_hex(path, a), whole) << checksum_algorithm_name(a);
    bytes[bytes.size() / 2] ^= 1;  // one bit flipped changes it
    EXPECT_NE(hex_of(a, std::string(bytes.begin(), bytes.end())), whole);
    bytes[bytes.size() / 2] ^= 1;
  }
  EXPECT_FALSE(file_checksum_hex((dir.path() / "absent").string(), ChecksumAlgorithm::Xxh3_64));
}
