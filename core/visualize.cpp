// Pictures of a night scene's intermediate maps (include/photosite/visualize.h).
#include "photosite/visualize.h"

#include <algorithm>
#include <cmath>
#include <filesystem>

#include <opencv2/imgproc.hpp>

#include "photosite/error.h"
#include "photosite/io.h"
#include "photosite/sensor/isp.h"
#include "photosite/sensor/spectrum.h"

namespace photosite {
namespace {
ImageF u8_to_unit(const ImageU8& m) {
  ImageF f(m.width(), m.height(), 1);
  for (size_t i = 0; i < f.size(); ++i) f[i] = m[i] / 255.f;
  return f;
}

// Edges in grey, the detected lines in amber and the vanishing point as a ring, at the work
// resolution of the line detector.
ImageF lines_picture(const scene::NightScene& ns) {
  const int w = ns.edges_work.width(), h = ns.edges_work.height();
  cv::Mat m(h, w, CV_32FC3, cv::Scalar(0, 0, 0));
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (ns.edges_work.at(x, y)) m.at<cv::Vec3f>(y, x) = cv::Vec3f(0.35f, 0.35f, 0.35f);
  for (const auto& l : ns.lines_work)
    cv::line(m, cv::Point2f(l.x0, l.y0), cv::Point2f(l.x1, l.y1), cv::Scalar(1, 0.8, 0), 2);
  const cv::Point2f vp((ns.vp.x + 0.5) * ns.work_scale - 0.5, (ns.vp.y + 0.5) * ns.work_scale - 0.5);
  cv::circle(m, vp, std::max(4, w / 100), cv::Scalar(1, 0, 0.2), 2);
  ImageF f(w, h, 3);
  std::copy_n(reinterpret_cast<float*>(m.data), f.size(), f.data());
  return f;
}
}  // namespace

ImageF depth_picture(const ImageF& depth_m) {
  // Metric depth on a log scale: 1 m white .. 1000 m black; the sky (65504) black.
  ImageF d(depth_m.width(), depth_m.height(), 1);
  for (size_t i = 0; i < d.size(); ++i)
    d[i] = static_cast<float>(std::clamp(1.0 - std::log10(std::max(1.0, static_cast<double>(depth_m[i]))) / 3, 0.0, 1.0));
  return d;
}

ImageF log_luminance_picture(const ImageF& rad) {
  ImageF f(rad.width(), rad.height(), 1);
  for (size_t i = 0; i < f.pixel_count(); ++i) {
    const float c[3] = {rad[3 * i], rad[3 * i + 1], rad[3 * i + 2]};
    const double L = spectrum::luminance_cd_m2(c);
    f[i] = static_cast<float>(std::clamp((std::log10(std::max(L, 1e-6)) + 3) / 6, 0.0, 1.0));
  }
  return f;
}

const std::vector<std::string>& night_map_picture_files() {
  static const std::vector<std::string> files = {"lanes.png", "edges.png", "lines_vp.png", "depth.png", "lights_log.png",
                                                 "darkened_log.png", "night_radiance_log.png", "labels.png", "day.png"};
  return files;
}

std::vector<NamedPicture> night_map_pictures(const ImageF& day, const scene::LabelMap& labels,
                                             const scene::NightScene& ns) {
  const auto& name = night_map_picture_files();
  std::vector<NamedPicture> p;
  p.push_back({name[0], u8_to_unit(ns.lanes_work)});
  p.push_back({name[1], u8_to_unit(ns.edges_work)});
  p.push_back({name[2], lines_picture(ns)});
  p.push_back({name[3], depth_picture(ns.depth)});
  p.push_back({name[4], log_luminance_picture(ns.lights)});
  p.push_back({name[5], log_luminance_picture(ns.darkened)});
  p.push_back({name[6], log_luminance_picture(ns.radiance)});
  ImageF pal(labels.ids.width(), labels.ids.height(), 3);
  for (size_t i = 0; i < labels.ids.pixel_count(); ++i)
    for (int k = 0; k < 3; ++k) pal[3 * i + k] = scene::label_color(labels.ids[i])[k] / 255.f;
  p.push_back({name[7], std::move(pal)});
  ImageF dayp(day.width(), day.height(), 3);
  for (size_t i = 0; i < dayp.size(); ++i) dayp[i] = static_cast<float>(srgb_encode(std::min(1.f, day[i])));
  p.push_back({name[8], std::move(dayp)});
  return p;
}

void write_pictures(const std::string& dir, const std::vector<NamedPicture>& pictures, bool overwrite) {
  namespace fs = std::filesystem;
  if (!fs::is_directory(dir)) fail_at(dir, "the folder for the pictures does not exist");
  std::vector<std::string> paths;
  for (const auto& p : pictures) {
    paths.push_back((fs::path(dir) / p.file).string());
    check_output_path(paths.back(), overwrite);
  }
  for (size_t i = 0; i < pictures.size(); ++i) write_png(paths[i], pictures[i].image);
}

}  // namespace photosite
