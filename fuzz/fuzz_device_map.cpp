// libFuzzer target: reading a device's fixed-pattern map (an OpenEXR file in the device store):
// the header checks (size, channels, photosite attributes) before any pixel is read, then the
// pixels and the checksum. The input is written as the map file of an 8x4 sony-imx174 device.
#include <sys/stat.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <string>


#include "photosite/error.h"
#include "photosite/sensor/fpn.h"

namespace {
photosite::CameraPreset g_preset;
std::string g_dir, g_file;
}

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  setenv("PHOTOSITE_MAX_PIXELS", "1048576", 1);
  setenv("PHOTOSITE_EXR_THREADS", "0", 1);  // OpenEXR without its worker pool
  g_preset = photosite::load_camera_preset("sony-imx174");
  g_dir = "/tmp/photosite-fuzz-map-" + std::to_string(getpid());
  mkdir(g_dir.c_str(), 0700);
  g_file = g_dir + "/dev_8x4.exr";
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::FILE* f = std::fopen(g_file.c_str(), "wb");
  std::fwrite(data, 1, size, f);
  std::fclose(f);
  try {
    photosite::DeviceStore store(g_dir);
    (void)store.load(g_file, g_preset, "dev", 8, 4);
  } catch (const photosite::Error&) {
  }
  return 0;
}
