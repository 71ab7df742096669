// Pictures for people: the intermediate maps of a night scene (the command line's --maps,
// docs/night.md), as display-ready images in [0, 1], and a writer that puts a set of them in a
// folder without leaving half a set behind.
#pragma once

#include <string>
#include <vector>

#include "photosite/image.h"
#include "photosite/scene/labels.h"
#include "photosite/scene/night.h"

namespace photosite {

struct NamedPicture {
  std::string file;  // e.g. "lanes.png"
  ImageF image;      // 1 or 3 channels, display values in [0, 1] (sRGB-encoded where colour)
};

// The maps of one night scene: lanes, edges, lines and the vanishing point (work resolution),
// depth (log scale, 1 m to 1 km), the light map, the darkened scene and the night radiance as log10 luminance from 1e-3 to
// 1e3 cd/m² mapped to [0, 1], the labels in the Cityscapes palette, and the day photo.
// day_linear: the linear sRGB day image the scene was made from.
std::vector<NamedPicture> night_map_pictures(const ImageF& day_linear, const scene::LabelMap& labels,
                                             const scene::NightScene& ns);
// Their file names, in that order (known before the scene is made: a run checks its outputs first).
const std::vector<std::string>& night_map_picture_files();

// Metric depth (m) on a log scale: 1 m white, 1000 m and beyond (the sky) black.
ImageF depth_picture(const ImageF& depth_m);

// log10 luminance of a radiance image (W·sr⁻¹·m⁻², box RGB) from 1e-3 to 1e3 cd/m², mapped to [0, 1].
ImageF log_luminance_picture(const ImageF& radiance);

// Writes every picture as an 8-bit PNG into `dir`, which must exist. Every path is checked first
// (bad input naming it if it exists and !overwrite), so a refusal writes nothing.
void write_pictures(const std::string& dir, const std::vector<NamedPicture>& pictures, bool overwrite);

}  // namespace photosite
