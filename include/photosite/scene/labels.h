// Semantic labels in the Cityscapes format (Cordts et al., CVPR 2016; cityscapesScripts
// helpers/labels.py), shared by Cityscapes, KITTI and BDD100K: labelIds 0..33, trainIds 0..18 with
// 255 for ignored, or the colour palette. Internally photosite always holds labelIds (uint8).
#pragma once
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "photosite/image.h"

namespace photosite::scene {

// The 34 Cityscapes labelIds (helpers/labels.py).
enum class Label : uint8_t {
  Unlabeled = 0, EgoVehicle = 1, RectificationBorder = 2, OutOfRoi = 3, Static = 4, Dynamic = 5,
  Ground = 6, Road = 7, Sidewalk = 8, Parking = 9, RailTrack = 10, Building = 11, Wall = 12,
  Fence = 13, GuardRail = 14, Bridge = 15, Tunnel = 16, Pole = 17, PoleGroup = 18,
  TrafficLight = 19, TrafficSign = 20, Vegetation = 21, Terrain = 22, Sky = 23, Person = 24,
  Rider = 25, Car = 26, Truck = 27, Bus = 28, Caravan = 29, Trailer = 30, Train = 31,
  Motorcycle = 32, Bicycle = 33,
};
inline constexpr int kLabelCount = 34;

enum class LabelFormat { Auto, LabelIds, TrainIds, Palette };
LabelFormat parse_label_format(const std::string& text);  // auto|labelIds|trainIds|color
const char* label_format_name(LabelFormat f);

const char* label_name(int label_id);
std::array<uint8_t, 3> label_color(int label_id);  // the Cityscapes palette colour
int train_id_to_label_id(int train_id);             // 255 → Unlabeled; unknown → -1
bool is_vehicle(int label_id);  // car, truck, bus, caravan, trailer, train, motorcycle, bicycle
bool is_ground(int label_id);   // road, sidewalk, parking, ground, rail track, terrain
// Not the scene: the frame's own car (ego vehicle), the rectification's border and out of ROI
// (inline: per-pixel tests call it, scene/lines.cpp's within a neighbourhood of each point).
inline bool is_not_scene(int label_id) {
  return label_id == static_cast<int>(Label::EgoVehicle) || label_id == static_cast<int>(Label::RectificationBorder) ||
         label_id == static_cast<int>(Label::OutOfRoi);
}
// is_ground() of every label id as one table, for per-pixel loops (DarkenParams::ground_class,
// the low beam, the street lamps' pools).
const std::array<bool, kLabelCount>& ground_classes();

// A per-label-id table (kLabelCount entries: std::array or a C array of bool) as a bit mask, bit k
// for label id k, for the vector loops' class tests (`classes >> id & 1`); ids of kLabelCount and
// above are in no set.
template <class Table>
uint64_t label_bits(const Table& in_set) {
  static_assert(kLabelCount <= 64);
  uint64_t bits = 0;
  for (int k = 0; k < kLabelCount; ++k)
    if (in_set[k]) bits |= uint64_t{1} << k;
  return bits;
}

struct LabelMap {
  ImageU16 ids;             // labelIds 0..33, one channel
  LabelFormat format = LabelFormat::LabelIds;  // what the file held
  ImageU16 instances;       // Cityscapes instance code class*1000+n (>= 1000), 0: none; empty without a file
  // Set when the format was detected and the file fits another reading too (values 0..18 only:
  // trainIds or labelIds); the console prints it.
  std::string note;
  // Sky seen through tree crowns (scene::take_sky_gaps): the pixels, in reading order, that the
  // file labels vegetation and the scene's stages take for sky; `ids` holds Sky (23) there from
  // take_sky_gaps until restore_sky_gaps gives the file's ids back (the outputs' labels.Y is the
  // file's). `sky_gaps_taken`: looked for (with or without any found), until restored.
  std::vector<uint32_t> sky_gaps;
  bool sky_gaps_taken = false;
  // The median day luminance of the labelled sky that take_sky_gaps compared with (linear sRGB,
  // Rec. 709); 0 where it found none (or was not asked: sky_gap_fraction 0).
  float sky_day_luminance = 0;
  // The median day luminance of the vegetation below the threshold (the leaves, sky-like pixels
  // left out; from a 1/64 sample) that unmix_sky_fringe mixes with the sky's; 0 where under 64
  // such pixels.
  float leaf_day_luminance = 0;
  // The vegetation pixels left beside the sky (8-neighbours, after the gaps were taken), in
  // reading order: the crown's edge, which unmix_sky_fringe scales.
  std::vector<uint32_t> sky_fringe;
};

// Interprets raw codes (1 channel: ids; 3 channels: palette) in `format` (Auto: detect). An
// unknown id or colour is a bad-input error naming `file` and the pixel.
LabelMap decode_labels(const ImageU16& raw, LabelFormat format, const std::string& file);

enum class ResizeLabels { None, Nearest };
// Reads labels (and optional Cityscapes *_instanceIds.png: id >= 1000 → class id/1000, instance
// id%1000; ids < 1000 are class ids without instances; KITTI's class*256+n instance PNGs are
// recognised when they agree with the labels) and checks they match width x height.
LabelMap read_labels(const std::string& labels_path, const std::string& instances_path,
                     int width, int height, LabelFormat format, ResizeLabels resize);

// read_labels() on codes already in memory (the Python module's arrays): `raw` as
// read_image_u16() returns it, `instances` null when there are none; the paths name the inputs
// in messages.
LabelMap labels_from_codes(ImageU16 raw, const ImageU16* instances, int width, int height, LabelFormat format,
                           ResizeLabels resize, const std::string& labels_path, const std::string& instances_path);

// Nearest-neighbour resize of a one-channel label/instance image.
ImageU16 resize_nearest(const ImageU16& in, int width, int height);

}  // namespace photosite::scene
