// The push-constant blocks of every kernel (photon, sense, darken, compose, linearize,
// poisson/philox_words, the glare kernels and the demosaic kernels), each defined ONCE in
// kernels/common/params_<kernel>.glsl and read by both languages: the kernel includes its file as
// its push-constant block (instance P), and gpu/kernels.h includes all of them as C++ structs
// (inside namespace photosite::shader, after common/prelude.glsl), with static_asserts that pin
// every size and offset to std430 (scalars 4-byte aligned, uvec2 8, double 8).
#ifndef PHOTOSITE_PUSH_CONSTANTS_GLSL
#define PHOTOSITE_PUSH_CONSTANTS_GLSL
#ifdef __cplusplus
#define PS_PUSH_CONSTANTS(name) struct name
#define PS_PUSH_INSTANCE
#else
#define PS_PUSH_CONSTANTS(name) layout(push_constant, std430) uniform name
#define PS_PUSH_INSTANCE P
#endif
#endif
