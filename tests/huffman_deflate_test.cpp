// Literal-only deflate (core/huffman_deflate.h): zlib's inflate reads every stream back to the
// input, the codes are complete prefix codes within their length limit, and on data whose
// code needs no limiting the size stays under Huffman's bound (entropy + 1 bit per symbol).
#include <gtest/gtest.h>
#include <zlib.h>

#include <cmath>
#include <random>

#include "core/huffman_deflate.h"

using namespace photosite;

namespace {
std::vector<uint8_t> inflate_all(const std::vector<uint8_t>& z, size_t size) {
  std::vector<uint8_t> back(size + 1);
  uLongf n = back.size();
  const int rc = uncompress(back.data(), &n, z.data(), z.size());
  EXPECT_EQ(rc, Z_OK);
  back.resize(n);
  return back;
}
double kraft(const std::vector<uint8_t>& len) {
  double k = 0;
  for (uint8_t l : len)
    if (l) k += std::ldexp(1.0, -l);
  return k;
}
// Shannon entropy in bits of each block of `block` bytes, summed.
double entropy_bits(const std::vector<uint8_t>& d, size_t block) {
  double bits = 0;
  for (size_t at = 0; at < d.size(); at += block) {
    const size_t n = std::min(block, d.size() - at);
    std::vector<double> h(257, 0);
    for (size_t i = 0; i < n; ++i) ++h[d[at + i]];
    h[256] = 1;  // end of block
    for (double c : h)
      if (c > 0) bits -= c * std::log2(c / (n + 1));
  }
  return bits;
}
}  // namespace

TEST(HuffmanDeflate, CodeLengthsAreCompleteAndLimited) {
  EXPECT_EQ(huffman_only::code_lengths({1, 1, 2, 4}, 15), (std::vector<uint8_t>{3, 3, 2, 1}));
  EXPECT_EQ(huffman_only::code_lengths({0, 0, 5, 0}, 15), (std::vector<uint8_t>{1, 0, 1, 0})) << "one symbol, one partner";
  EXPECT_EQ(huffman_only::code_lengths({0, 0, 0}, 15), (std::vector<uint8_t>{0, 0, 0}));
  // Fibonacci frequencies give the deepest Huffman tree (depth n-1): the limit must bite.
  std::vector<uint32_t> fib = {1, 1};
  while (fib.size() < 30) fib.push_back(fib[fib.size() - 1] + fib[fib.size() - 2]);
  for (int max_bits : {7, 15}) {
    const auto len = huffman_only::code_lengths(fib, max_bits);
    EXPECT_EQ(*std::max_element(len.begin(), len.end()), max_bits);
    EXPECT_DOUBLE_EQ(kraft(len), 1.0) << "a complete code";
  }
  const auto unlimited = huffman_only::code_lengths(fib, 64);
  EXPECT_EQ(*std::max_element(unlimited.begin(), unlimited.end()), 29);
}

TEST(HuffmanDeflate, InflateReadsEveryStreamBack) {
  std::mt19937 rng(7);
  std::geometric_distribution<int> steep(0.5);  // codes longer than 15 bits without the limit
  std::vector<std::vector<uint8_t>> cases = {{}, {42}, std::vector<uint8_t>(100000, 9)};
  std::vector<uint8_t> uniform(300000), geometric(200000), mixed(150000);
  for (auto& b : uniform) b = static_cast<uint8_t>(rng());
  for (auto& b : geometric) b = static_cast<uint8_t>(std::min(steep(rng), 255));
  for (size_t i = 0; i < mixed.size(); ++i) mixed[i] = i < 70000 ? static_cast<uint8_t>(rng() % 4) : static_cast<uint8_t>(rng());
  cases.push_back(uniform);
  cases.push_back(geometric);
  cases.push_back(mixed);
  for (const auto& d : cases)
    for (const size_t block : {size_t{1}, size_t{1000}, size_t{1} << 16}) {
      SCOPED_TRACE(::testing::Message() << d.size() << " bytes, blocks of " << block);
      if (block == 1 && d.size() > 1000) continue;
      const auto z = huffman_only::zlib_stream(d.data(), d.size(), block);
      EXPECT_EQ(inflate_all(z, d.size()), d);
    }
}

TEST(HuffmanDeflate, SizeWithinHuffmansBoundOfTheEntropy) {
  // A Huffman code's mean length is below H + 1 bits per symbol (Cover & Thomas, Thm 5.4.1);
  // each block also carries its header: at most 3+5+5+4 + 19*3 bits and 258 run-length
  // symbols of at most 7+7 bits. The frequency-halving limit does not bite on these data (their
  // unlimited codes are at most 15 bits long), so the bound holds exactly.
  std::mt19937 rng(11);
  std::normal_distribution<double> residual(0, 6);  // filtered sensor noise: near-Laplacian bytes
  std::vector<uint8_t> d(1 << 20);
  for (auto& b : d) b = static_cast<uint8_t>(static_cast<int>(std::lround(residual(rng))));
  const size_t block = size_t{1} << 16;
  const auto z = huffman_only::zlib_stream(d.data(), d.size(), block);
  const double blocks = std::ceil(static_cast<double>(d.size()) / block);
  const double bound_bits = entropy_bits(d, block) + (d.size() + blocks) + blocks * (17 + 57 + 258 * 14) + 7;
  EXPECT_LE((z.size() - 6) * 8.0, bound_bits);
  EXPECT_EQ(inflate_all(z, d.size()), d);
}
