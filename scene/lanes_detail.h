// Private (not installed): the working luminance of make_work_images (scene/lanes.cpp) row by
// row, so that the texture's second pass (scene/darken.cpp) computes it while the day image's
// rows are still in cache (night_scene, scene/night.cpp), instead of a pass of its own over the
// 24 MB frame.
#pragma once
#include "photosite/scene/night.h"

namespace photosite::scene {

// The working size of a W x H frame for work_max_width (make_work_images' rule), and whether it
// is the exact halving (W = 2·ww, H = 2·wh, ww a multiple of 16) whose rows work_luma_row makes.
struct WorkSize {
  int width = 1, height = 1;
  double scale = 1.0;
  bool halving = false;
};
WorkSize work_size(int width, int height, int work_max_width);
// Row y of the working luminance in the halving case: the 2x2 mean of day rows 2y and 2y + 1
// (Rec. 709 luminance of linear sRGB), sRGB-encoded, into out (ww floats).
void work_luma_row(const ImageF& day_linear_srgb, int y, float* out);
// The widest instruction set work_luma_row's 2x2 means and the sRGB encode (srgb_encode_floats)
// may take: 2 AVX-512, 1 AVX2, 0 the scalar loop (default 2; the machine's own support caps it).
// All give the same bits; the tests run each.
void work_luma_max_isa(int isa);
// The lane stage's Gaussian blur of the working luminance (σ in pixels): cv::GaussianBlur of the
// whole image (default border), computed in `bands` row bands in parallel (0: one per OpenMP
// thread, at most 8), the same bits for any band count.
ImageF lane_blur(const ImageF& luma, double sigma_px, int bands = 0);
// One row of lane_markings' filter, columns [w, W − w) of row r (W floats): 255 into o where the
// label is road or parking and h = 2c − l − r − |l − r| over the pixels w to either side exceeds
// 2·thr, or, with the rows up and down (null: none), the same across rows; o is left as it is
// elsewhere. Also the markings of `bench markings` (scene/depth_eval.cpp), with a metric w.
void lane_row(const float* __restrict r, const float* __restrict up, const float* __restrict down,
              const uint16_t* __restrict lab, int W, int w, float thr, uint8_t* __restrict o);
// make_work_images with its luminance already made (work_luma_row over every row, a
// ww x wh image moved in), or computed here when luma is null.
WorkImages make_work_images_with(const ImageF& day_linear_srgb, const ImageU16& labels, int work_max_width,
                                 ImageF* luma);
// One row of segmentation_edges' grey-level rendering of the selected classes (scene/edges.cpp):
// markings 255, road and parking 80, vehicles 160, everything else 0, from a row of labels and
// of lane markings (W pixels each) into o.
void segmentation_grey_row(const uint16_t* labels, const uint8_t* lanes, int W, uint8_t* o);
// lane_markings, and with `grey` also segmentation_edges' grey rendering of the same labels and
// these markings (segmentation_grey_row of every row, a W x H image made here), each row right
// after its markings while both rows are in cache, on the threads of the markings' own loop
// (night_scene; segmentation_edges_of_grey then runs Canny on it).
ImageU8 lane_markings_with_grey(const ImageF& luma, const ImageU16& labels, const ScenePreset& p, ImageU8* grey);
// segmentation_edges given its grey rendering (segmentation_grey_row of every row of the labels
// and markings): Canny of it; the same edges to the bit.
ImageU8 segmentation_edges_of_grey(const ImageU8& grey, const ScenePreset& p);

}  // namespace photosite::scene
