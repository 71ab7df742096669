// Throwaway (twenty-seventh session, reverted in the next commit): the bound of reading an 8-bit
// frame through the decode table on this host. decode8_samples_vbmi's loop over a 2048x1024 frame's
// codes (a) into a thread's L1 block, (b) into a 24 MB image (fresh, and reused on 2 MB pages), (c) a
// streaming read of the 24 MB image (pass 2's re-read); OpenMP over 64 chunks as the texture passes.
// Build: g++ -O2 -mavx512f -mavx512bw -mavx512vbmi -fopenmp -o bound decode8_bound.cpp
#include <immintrin.h>
#include <omp.h>
#include <chrono>
#include <cstdio>
#include <cstdint>
#include <cmath>
#include <cstdlib>
#include <vector>
#include <cstring>
#include <sys/mman.h>
#include <algorithm>
struct D8 { alignas(64) float out[256]; alignas(64) uint8_t plane[4][256]; };
struct Ord { alignas(64) uint8_t idx[64]; Ord(){ for(int L=0;L<4;++L)for(int k=0;k<4;++k)for(int e=0;e<4;++e) idx[16*L+4*k+e]=16*k+4*L+e;} };
static Ord ord;
__attribute__((target("avx512f,avx512bw,avx512vbmi"))) void dec(const uint8_t* c, int n, const D8& d8, float* o) {
  __m512i t[4][4];
  for (int b = 0; b < 4; ++b) for (int q = 0; q < 4; ++q) t[b][q] = _mm512_load_si512(d8.plane[b] + 64 * q);
  const __m512i order = _mm512_load_si512(ord.idx);
  int j = 0;
  for (; j + 64 <= n; j += 64) {
    const __m512i code = _mm512_maskz_permutexvar_epi8(~__mmask64{0}, order, _mm512_loadu_si512(c + j));
    const __mmask64 upper = _mm512_movepi8_mask(code);
    __m512i byte[4];
    for (int b = 0; b < 4; ++b) byte[b] = _mm512_mask_blend_epi8(upper, _mm512_permutex2var_epi8(t[b][0], code, t[b][1]), _mm512_permutex2var_epi8(t[b][2], code, t[b][3]));
    const __m512i lo01 = _mm512_unpacklo_epi8(byte[0], byte[1]), hi01 = _mm512_unpackhi_epi8(byte[0], byte[1]);
    const __m512i lo23 = _mm512_unpacklo_epi8(byte[2], byte[3]), hi23 = _mm512_unpackhi_epi8(byte[2], byte[3]);
    _mm512_storeu_si512(o + j, _mm512_unpacklo_epi16(lo01, lo23));
    _mm512_storeu_si512(o + j + 16, _mm512_unpackhi_epi16(lo01, lo23));
    _mm512_storeu_si512(o + j + 32, _mm512_unpacklo_epi16(hi01, hi23));
    _mm512_storeu_si512(o + j + 48, _mm512_unpackhi_epi16(hi01, hi23));
  }
  for (; j < n; ++j) o[j] = d8.out[c[j]];
}
double now(){ return std::chrono::duration<double,std::milli>(std::chrono::steady_clock::now().time_since_epoch()).count(); }
int main() {
  const size_t np = 2048 * 1024, ns = 3 * np; const int B = 256;
  static D8 d8; for (int i = 0; i < 256; ++i) { float v = i / 255.f; d8.out[i] = v <= 0.04045f ? v / 12.92f : std::pow((v + 0.055f) / 1.055f, 2.4f); uint32_t u; memcpy(&u,&d8.out[i],4); for(int b=0;b<4;++b) d8.plane[b][i]=(u>>(8*b))&255; }
  std::vector<uint8_t> codes(ns); for (auto& c : codes) c = rand() & 255;
  float* reused_p = static_cast<float*>(aligned_alloc(1 << 21, ((ns * 4 + (1 << 21) - 1) >> 21) << 21));
  madvise(reused_p, ((ns * 4 + (1 << 21) - 1) >> 21) << 21, MADV_HUGEPAGE);
  std::fill(reused_p, reused_p + ns, 0.f);
  struct { float* p; float* data() { return p; } } reused{reused_p};
  volatile float sink = 0;
  for (int rep = 0; rep < 7; ++rep) {
    double a0 = now(); float acc = 0;
#pragma omp parallel for schedule(static) reduction(+:acc)
    for (int ch = 0; ch < 64; ++ch) { alignas(64) float buf[3 * B]; size_t i0 = np * ch / 64, i1 = np * (ch + 1) / 64;
      for (size_t b = i0; b < i1; b += B) { int nb = (int)std::min<size_t>(B, i1 - b); dec(codes.data() + 3 * b, 3 * nb, d8, buf); acc += buf[0] + buf[3*nb-1]; } }
    double a1 = now();
    float* fresh = static_cast<float*>(malloc(ns * 4));
#pragma omp parallel for schedule(static)
    for (int ch = 0; ch < 64; ++ch) { size_t i0 = np * ch / 64, i1 = np * (ch + 1) / 64;
      for (size_t b = i0; b < i1; b += B) { int nb = (int)std::min<size_t>(B, i1 - b); dec(codes.data() + 3 * b, 3 * nb, d8, fresh + 3 * b); } }
    double a2 = now();
#pragma omp parallel for schedule(static)
    for (int ch = 0; ch < 64; ++ch) { size_t i0 = np * ch / 64, i1 = np * (ch + 1) / 64;
      for (size_t b = i0; b < i1; b += B) { int nb = (int)std::min<size_t>(B, i1 - b); dec(codes.data() + 3 * b, 3 * nb, d8, reused.data() + 3 * b); } }
    double a3 = now();
    // streaming read of the image (sum, 16 lanes)
    float r = 0;
#pragma omp parallel for schedule(static) reduction(+:r)
    for (int ch = 0; ch < 64; ++ch) { size_t i0 = 3 * (np * ch / 64), i1 = 3 * (np * (ch + 1) / 64); __m512 s = _mm512_setzero_ps();
      for (size_t i = i0; i + 16 <= i1; i += 16) s = _mm512_add_ps(s, _mm512_loadu_ps(reused_p + i)); r += _mm512_reduce_add_ps(s); }
    double a4 = now();
    sink = acc + r; free(fresh);
    printf("decode->L1 %.2f  decode->fresh24MB %.2f  decode->reused24MB(2MB pages) %.2f  read24MB %.2f ms\n", a1 - a0, a2 - a1, a3 - a2, a4 - a3);
  }
}
