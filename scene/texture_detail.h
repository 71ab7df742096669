// Private (not installed): a test hook of scene/darken.cpp's linearize and reflectance_texture.
#pragma once

namespace photosite::scene {

// The widest instruction set linearize's and reflectance_texture's per-pixel loops may take: 2 AVX-512, 1 AVX2,
// 0 the scalar loops (default 2; the machine's own support caps it). All give the same bits; the
// test runs each.
void texture_max_isa(int isa);

}  // namespace photosite::scene
