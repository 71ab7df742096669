// The per-pixel maths of scene::darken, written once in the C++/GLSL common subset
// (common/prelude.glsl) for scene/darken_detail.h (darken_pixel: scene::darken and scene::compose) and
// kernels/darken.comp. A Lambertian texture f under the class's night
// illuminance, L_k = f_k · E_k (E = the ambient illuminance / π, float); the sky its glow
// colour scaled by the pixel's relative luminance (double), L_k = glow_k · (Σ K_j f_j) / ρ_sky.
#ifndef PHOTOSITE_DARKEN_GLSL
#define PHOTOSITE_DARKEN_GLSL

// (Σ K_j f_j) / ρ_sky: the sky pixel's luminance relative to the class mean, K the box bands'
// luminous efficacies (lm/W).
PS_FN double darken_sky_relative(double k0, double k1, double k2, double rho_sky, float t0, float t1, float t2) {
  precise double yr = (k0 * double(t0) + k1 * double(t1) + k2 * double(t2)) / rho_sky;
  return yr;
}
PS_FN float darken_sky_channel(double glow, double yr) { return float(glow * yr); }
// f_k · E_k for a lit (non-sky) class.
PS_FN float darken_lit_channel(float t, float e) {
  precise float l = t * e;
  return l;
}

#endif
