// A zlib stream (RFC 1950) of deflate blocks (RFC 1951) that hold literals only: each block's
// byte histogram gets its own length-limited Huffman code, and no string matching is done.
// This is what zlib's Z_HUFFMAN_ONLY strategy writes, for the same reason: on noisy sensor
// previews LZ77 finds few matches, so its search costs time and its matches cost bits (the
// filtered rows are near-Laplacian residuals, whose entropy a per-block Huffman code reaches
// within a few percent). zlib pays about 10 ns a byte for it (one call per symbol into its
// block tally); here a block is a histogram, a code and one tight bit-packing loop.
// Private header (core/ and tests only).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace photosite::huffman_only {

// Code lengths (at most max_bits) of a prefix code for the symbols of `freq`: Huffman's
// construction, with the frequencies halved (rounded up, 0 stays 0) and the code rebuilt while
// the longest code exceeds max_bits. Zero-frequency symbols get length 0. One used symbol gets
// length 1 and a partner symbol length 1 too, so the code is complete, as inflaters demand.
// Ties are broken by symbol index: the result depends on the frequencies alone.
std::vector<uint8_t> code_lengths(const std::vector<uint32_t>& freq, int max_bits);

// The whole zlib stream of `data`: header 0x78 0x01, dynamic-Huffman literal blocks of at most
// `block_bytes` bytes, end-of-block codes, the last block marked final, Adler-32.
std::vector<uint8_t> zlib_stream(const uint8_t* data, size_t size, size_t block_bytes = 1 << 16);

}  // namespace photosite::huffman_only
