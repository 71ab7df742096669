// Private (not installed): a test hook of scene/darken.cpp's linearize and reflectance_texture,
// and the texture pass that also makes the lane stage's working luminance.
#pragma once
#include "photosite/scene/night.h"

namespace photosite::scene {

// The widest instruction set linearize's and reflectance_texture's per-pixel loops may take: 2 AVX-512, 1 AVX2,
// 0 the scalar loops (default 2; the machine's own support caps it). All give the same bits; the
// test runs each.
void texture_max_isa(int isa);

// reflectance_texture, and with work_luma (a ww x wh image for a 2ww x 2wh frame: the exact
// halving of scene/lanes_detail.h) also the working luminance, work_luma_row of every row,
// made in the texture's second pass while each chunk's day pixels are in cache (night_scene).
// `sums`: pass 1 made by linearize_with_texture_sums (taken when made for day and labels).
ImageF reflectance_texture_with(const ImageF& day_linear_srgb, const ImageU16& labels, const ScenePreset& p,
                                ClassMeans* carried, ImageF* work_luma, const TextureSums* sums = nullptr);

// linearize_with_texture_sums of an 8-bit sRGB file's codes (interleaved RGB, the frame's size;
// other channel counts: linearize() alone): the same image and sums to the bit as from the
// codes' floats code·(1/255) that read_image() gives, reading a quarter of the bytes (each code's
// linear value from linearize()'s own 256-entry table for 8-bit files).
ImageF linearize_codes_with_texture_sums(const ImageU8& codes, const ImageU16& labels, TextureSums* sums);

}  // namespace photosite::scene
