// Literal-only deflate (see huffman_deflate.h). The format is RFC 1951 section 3.2: a dynamic
// block's header gives HLIT, HDIST and HCLEN, the code-length code's lengths in the fixed
// permuted order, then the literal/length and distance code lengths, run-length coded with
// symbols 16 (repeat the previous 3-6 times), 17 (3-10 zeros) and 18 (11-138 zeros). Huffman
// codes are canonical (3.2.2) and sent most significant bit first inside an LSB-first stream,
// so each code is stored bit-reversed.
#include "core/huffman_deflate.h"

#include <libdeflate.h>

#include <algorithm>
#include <array>
#include <queue>

#include "photosite/error.h"

namespace photosite::huffman_only {

std::vector<uint8_t> code_lengths(const std::vector<uint32_t>& freq_in, int max_bits) {
  const int n = static_cast<int>(freq_in.size());
  std::vector<uint8_t> len(n, 0);
  std::vector<uint64_t> freq(freq_in.begin(), freq_in.end());
  int used = 0, only = -1;
  for (int s = 0; s < n; ++s)
    if (freq[s]) ++used, only = s;
  if (used == 0) return len;
  if (used == 1) {  // a complete one-bit code: the symbol and a partner
    len[only] = 1;
    len[only == 0 ? 1 : 0] = 1;
    return len;
  }
  for (;;) {
    // Huffman's merge of the two lightest nodes; nodes n.. are internal. Ties: lower index first.
    using Node = std::pair<uint64_t, int>;
    std::priority_queue<Node, std::vector<Node>, std::greater<>> q;
    std::vector<int> parent(2 * n, -1);
    for (int s = 0; s < n; ++s)
      if (freq[s]) q.emplace(freq[s], s);
    int next = n;
    while (q.size() > 1) {
      const Node a = q.top();
      q.pop();
      const Node b = q.top();
      q.pop();
      parent[a.second] = parent[b.second] = next;
      q.emplace(a.first + b.first, next++);
    }
    int longest = 0;
    std::vector<int> depth(2 * n, 0);
    for (int v = next - 2; v >= n; --v) depth[v] = depth[parent[v]] + 1;  // parents come later
    for (int s = 0; s < n; ++s)
      if (freq[s]) {
        const int d = depth[parent[s]] + 1;
        len[s] = static_cast<uint8_t>(d);
        longest = std::max(longest, d);
      }
    if (longest <= max_bits) return len;
    for (auto& f : freq)
      if (f) f = (f + 1) / 2;  // flatter frequencies give a shallower tree
  }
}

namespace {
// Canonical codes of `len` (RFC 1951 3.2.2), bit-reversed for the LSB-first stream.
std::vector<uint16_t> canonical_codes(const std::vector<uint8_t>& len) {
  std::array<uint16_t, 16> count{}, next{};
  for (uint8_t l : len) ++count[l];
  count[0] = 0;
  uint16_t code = 0;
  for (int b = 1; b < 16; ++b) next[b] = code = static_cast<uint16_t>((code + count[b - 1]) << 1);
  std::vector<uint16_t> out(len.size(), 0);
  for (size_t s = 0; s < len.size(); ++s) {
    if (!len[s]) continue;
    uint16_t c = next[len[s]]++, r = 0;
    for (int i = 0; i < len[s]; ++i) r = static_cast<uint16_t>(r << 1 | (c >> i & 1));
    out[s] = r;
  }
  return out;
}

struct BitWriter {
  std::vector<uint8_t>& out;
  uint64_t acc = 0;
  int n = 0;
  void put(uint32_t bits, int count) {  // count <= 32
    acc |= static_cast<uint64_t>(bits) << n;
    n += count;
    if (n >= 32) {
      for (int i = 0; i < 4; ++i) out.push_back(static_cast<uint8_t>(acc >> (8 * i)));
      acc >>= 32;
      n -= 32;
    }
  }
  void flush() {  // to a byte boundary
    while (n > 0) {
      out.push_back(static_cast<uint8_t>(acc));
      acc >>= 8;
      n -= 8;
    }
    n = 0;
    acc = 0;
  }
};

void write_block(BitWriter& w, const uint8_t* data, size_t size, bool final) {
  // Literal/length alphabet: the 256 byte values and end-of-block (256); no length codes.
  std::array<std::array<uint32_t, 256>, 4> h{};  // four histograms: no store-to-load chain
  size_t i = 0;
  for (; i + 4 <= size; i += 4) ++h[0][data[i]], ++h[1][data[i + 1]], ++h[2][data[i + 2]], ++h[3][data[i + 3]];
  for (; i < size; ++i) ++h[0][data[i]];
  std::vector<uint32_t> freq(257);
  for (int s = 0; s < 256; ++s) freq[s] = h[0][s] + h[1][s] + h[2][s] + h[3][s];
  freq[256] = 1;
  const std::vector<uint8_t> lit_len = code_lengths(freq, 15);
  const std::vector<uint16_t> lit_code = canonical_codes(lit_len);

  // The code lengths of both alphabets (257 literal/length, 1 distance code of length 0: no
  // distances are used), run-length coded.
  std::vector<uint8_t> lens(lit_len);
  lens.push_back(0);
  std::vector<std::pair<uint8_t, uint8_t>> rle;  // (symbol 0..18, extra bits value)
  for (size_t k = 0; k < lens.size();) {
    size_t run = 1;
    while (k + run < lens.size() && lens[k + run] == lens[k]) ++run;
    const uint8_t l = lens[k];
    size_t left = run;
    if (l == 0) {
      while (left >= 11) { const size_t r = std::min<size_t>(left, 138); rle.emplace_back(18, r - 11); left -= r; }
      if (left >= 3) { rle.emplace_back(17, left - 3); left = 0; }
    } else {
      rle.emplace_back(l, 0);
      --left;
      while (left >= 3) { const size_t r = std::min<size_t>(left, 6); rle.emplace_back(16, r - 3); left -= r; }
    }
    for (; left > 0; --left) rle.emplace_back(l, 0);
    k += run;
  }
  std::vector<uint32_t> cl_freq(19, 0);
  for (const auto& [sym, extra] : rle) ++cl_freq[sym];
  const std::vector<uint8_t> cl_len = code_lengths(cl_freq, 7);
  const std::vector<uint16_t> cl_code = canonical_codes(cl_len);
  static constexpr int kOrder[19] = {16, 17, 18, 0, 8, 7, 9, 6, 10, 5, 11, 4, 12, 3, 13, 2, 14, 1, 15};
  int hclen = 19;
  while (hclen > 4 && cl_len[kOrder[hclen - 1]] == 0) --hclen;

  w.put(final ? 1 : 0, 1);
  w.put(2, 2);          // BTYPE 10: dynamic Huffman codes
  w.put(257 - 257, 5);  // HLIT: 257 literal/length codes
  w.put(1 - 1, 5);      // HDIST: 1 distance code
  w.put(static_cast<uint32_t>(hclen - 4), 4);
  for (int k = 0; k < hclen; ++k) w.put(cl_len[kOrder[k]], 3);
  static constexpr int kExtra[19] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 2, 3, 7};
  for (const auto& [sym, extra] : rle) {
    w.put(cl_code[sym], cl_len[sym]);
    if (kExtra[sym]) w.put(extra, kExtra[sym]);
  }
  // The literals, two codes (at most 30 bits) per put.
  std::array<uint32_t, 256> code32{};
  std::array<int, 256> bits{};
  for (int s = 0; s < 256; ++s) code32[s] = lit_code[s], bits[s] = lit_len[s];
  size_t k = 0;
  for (; k + 2 <= size; k += 2) {
    const uint8_t a = data[k], b = data[k + 1];
    w.put(code32[a] | code32[b] << bits[a], bits[a] + bits[b]);
  }
  if (k < size) w.put(code32[data[k]], bits[data[k]]);
  w.put(lit_code[256], lit_len[256]);
}
}  // namespace

std::vector<uint8_t> zlib_stream(const uint8_t* data, size_t size, size_t block_bytes) {
  if (block_bytes == 0) internal_error("huffman_only::zlib_stream: a block of at least one byte");
  std::vector<uint8_t> out;
  out.reserve(size + size / 8 + 64);
  out.push_back(0x78);  // CMF: deflate, 32 KiB window
  out.push_back(0x01);  // FLG: fastest compression, no dictionary; (0x78 << 8 | 0x01) % 31 == 0
  BitWriter w{out};
  if (size == 0) {
    w.put(1, 1);  // one final fixed-Huffman block holding only end-of-block (code 0000000)
    w.put(1, 2);
    w.put(0, 7);
  }
  for (size_t at = 0; at < size; at += block_bytes) {
    const size_t n = std::min(block_bytes, size - at);
    write_block(w, data + at, n, at + n == size);
  }
  w.flush();
  const uint32_t adler = libdeflate_adler32(1, data, size);
  for (int s = 24; s >= 0; s -= 8) out.push_back(static_cast<uint8_t>(adler >> s));
  return out;
}

}  // namespace photosite::huffman_only
