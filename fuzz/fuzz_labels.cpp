// libFuzzer target: label-format detection and loading. Byte 0 picks the path and the format
// (auto, labelIds, trainIds, color), bytes 1-2 the frame size (2..65). Path 0 decodes a label
// image built straight from the remaining bytes (detection and decoding only, fast); path 1
// writes them to a file and loads it as labels through core/io.cpp (PNG, JPEG, TIFF or OpenEXR),
// resized to the frame; path 2 loads the file as instance ids beside constant labels.
#include <sys/stat.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <string>


#include "photosite/error.h"
#include "photosite/io.h"
#include "photosite/scene/labels.h"

namespace {
std::string g_file, g_labels;
}

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  setenv("PHOTOSITE_MAX_PIXELS", "1048576", 1);  // declared sizes above 1 Mpx are refused
  const std::string dir = "/tmp/photosite-fuzz-labels-" + std::to_string(getpid());
  mkdir(dir.c_str(), 0700);
  g_file = dir + "/input";
  g_labels = dir + "/labels.png";
  photosite::ImageF road(65, 65, 1, 7 / 255.f);
  photosite::write_png(g_labels, road);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace photosite;
  if (size < 4) return 0;
  const int path = data[0] % 3;
  const auto format = static_cast<scene::LabelFormat>((data[0] / 3) % 4);
  const int w = 2 + data[1] % 64, h = 2 + data[2] % 64;
  data += 3;
  size -= 3;
  try {
    if (path == 0) {
      const int c = 1 + data[0] % 4;
      const bool wide = data[0] & 0x80;  // 16-bit values from byte pairs, else 8-bit
      ImageU16 raw(w, h, c, 0);
      for (size_t i = 0; i < raw.size(); ++i) {
        const unsigned lo = data[(1 + 2 * i) % size], hi = wide ? data[(2 + 2 * i) % size] : 0u;
        raw[i] = static_cast<uint16_t>(lo | hi << 8);
      }
      (void)scene::decode_labels(raw, format, "fuzz.png");
    } else {
      std::FILE* f = std::fopen(g_file.c_str(), "wb");
      std::fwrite(data, 1, size, f);
      std::fclose(f);
      if (path == 1)
        (void)scene::read_labels(g_file, "", w, h, format, scene::ResizeLabels::Nearest);
      else
        (void)scene::read_labels(g_labels, g_file, 65, 65, scene::LabelFormat::LabelIds,
                                 scene::ResizeLabels::Nearest);
    }
  } catch (const Error&) {
  }
  return 0;
}
