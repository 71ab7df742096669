// The per-pixel maths of the photon and sense stages, written once in the C++/GLSL common
// subset (common/prelude.glsl) for photosite::mean_signal_electrons and photosite::sense
// (sensor/pipeline.cpp, through sensor/pixel_detail.h) and for kernels/photon.comp and
// kernels/sense.comp. The includer provides fastmath.glsl before it.
#ifndef PHOTOSITE_SENSOR_PIXEL_GLSL
#define PHOTOSITE_SENSOR_PIXEL_GLSL

// ---- photon stage: radiance RGB (W·sr⁻¹·m⁻²) → mean photo-electrons -------------------------
// Radiance is physical when no channel is negative or NaN and R+G+B is finite (an R+G+B that
// overflows to Inf counts as non-physical too).
PS_FN bool radiance_is_physical(float r, float g, float b) {
  precise float sum = r + g + b;
  const bool finite = (floatBitsToUint(sum) & 0x7f800000u) != 0x7f800000u;
  return r >= 0.0f && g >= 0.0f && b >= 0.0f && finite;
}
// e = M[c]·(R, G, B) in double (m0..m2: the pixel's CFA colour row of photon_matrix(), electrons
// per unit radiance), divided by (1 + t²)² for cos⁴θ natural vignetting, where tan θ = r/f and
// t² = (dx² + dy²)·(pitch/f)², dx, dy the pixel's offset from the optical centre (pixels);
// pitch_over_f = 0: no falloff. dy2 = dy² is passed in (it is the same along a row).
PS_FN float photon_electrons(double m0, double m1, double m2, float r, float g, float b, double dx, double dy2,
                             double pitch_over_f) {
  precise double e = m0 * double(r) + m1 * double(g) + m2 * double(b);
  if (pitch_over_f > double(0.0f)) {
    precise double t2 = (dx * dx + dy2) * pitch_over_f * pitch_over_f;
    e /= (double(1.0f) + t2) * (double(1.0f) + t2);
  }
  return float(e);
}

// ---- sense stage: mean photo-electrons → electrons and DN ------------------------------------
// Mean collected electrons: photo-signal through the pixel's PRNU gain, plus dark charge at
// this pixel's dark rate. One Poisson draw of the sum is exactly the sum of the two independent
// Poisson processes (photon shot noise and dark-current shot noise).
//
// The mean is held at kMeanElectronsCap = 2^31 e⁻, twenty times the largest full well a preset may
// have (1e8 e⁻, sensor/preset.cpp): a draw there is 2^31 ± 5·2^15.5 (5σ), far above any well, so
// the pixel saturates exactly as with a larger mean, and a signal that overflowed float (+Inf, from
// a radiance or a photon count near float's largest value) saturates it too instead of making the
// draw NaN. Below the cap min() changes nothing.
const float kMeanElectronsCap = 2147483648.0f;  // 2^31, exact in float
PS_FN float sense_mean_e(float signal_e, float prnu_gain, float dark_mean_e, float dark_rate_factor) {
  precise float mean = signal_e * prnu_gain + dark_mean_e * dark_rate_factor;
  return min(mean, kMeanElectronsCap);
}
// The well holds no more than its capacity.
PS_FN float sense_electrons(float drawn_e, float full_well_e) { return min(drawn_e, full_well_e); }
// The analog chain in electrons: offset DSNU, read noise σ_read·z, row and column noise (double);
// then the conversion gain K (DN/e⁻), the black level and one rounding (ideal 1/12 DN²
// quantization), clipped to the ADC's codes [0, max_code].
PS_FN float sense_raw_dn(float e, float dsnu_e, float read_noise_e, float read_z, float row_e, float col_e,
                         double gain_dn_per_e, double black_dn, double max_code) {
  precise float rn = read_noise_e * read_z;
  precise double v = double(e) + double(dsnu_e) + double(rn) + double(row_e) + double(col_e);
  precise double dn = floor(v * gain_dn_per_e + black_dn + double(0.5f));
  return float(clamp(dn, double(0.0f), max_code));
}

#endif
