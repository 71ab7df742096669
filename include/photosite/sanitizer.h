// PHOTOSITE_ASAN is 1 in a build with AddressSanitizer (scripts/sanitize.sh, fuzz/): gcc says so
// with __SANITIZE_ADDRESS__, clang with __has_feature(address_sanitizer).
#pragma once
#if defined(__SANITIZE_ADDRESS__)
#define PHOTOSITE_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define PHOTOSITE_ASAN 1
#endif
#endif
#ifndef PHOTOSITE_ASAN
#define PHOTOSITE_ASAN 0
#endif
