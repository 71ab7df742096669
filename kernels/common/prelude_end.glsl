// Closes a block of shared files in C++ (common/prelude.glsl): removes its macros, so that
// `precise` and PS_FN do not leak into the code that follows. Nothing in GLSL.
#ifdef __cplusplus
#undef precise
#undef PS_FN
#endif
