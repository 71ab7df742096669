#include "photosite/rng.h"

namespace photosite {

uint64_t seed_from_device_id(const char* device_id) {
  uint64_t h = 0xcbf29ce484222325ull;  // FNV-1a 64-bit offset basis
  for (const char* p = device_id; *p; ++p) {
    h ^= static_cast<unsigned char>(*p);
    h *= 0x100000001b3ull;  // FNV prime
  }
  // SplitMix64 finalizer (Steele, Lea & Flood 2014) to spread the bits.
  h += 0x9e3779b97f4a7c15ull;
  h = (h ^ (h >> 30)) * 0xbf58476d1ce4e5b9ull;
  h = (h ^ (h >> 27)) * 0x94d049bb133111ebull;
  return h ^ (h >> 31);
}

}  // namespace photosite
