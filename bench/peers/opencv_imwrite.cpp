// libphotosite_opencv_peers.so: OpenCV's imwrite, a peer that `photosite bench batch` times beside
// photosite's own writers (issue 16 §4: "OpenCV writing the same layers"). It is a module that
// the bench loads with dlopen when it runs: linking opencv_imgcodecs into the command itself
// would load its dependency closure (GDAL, DCMTK, Poppler...: about 140 shared libraries) at
// every start of every command (docs/benchmarks.md "Start-up").
#include <cstddef>
#include <exception>
#include <vector>

#include <opencv2/imgcodecs.hpp>

// Writes the rows x cols image of OpenCV type `type` at `data` (row pitch `step` bytes) to `path`
// with imwrite's parameters; 1 when written, 0 when not (imwrite's false or an exception).
extern "C" __attribute__((visibility("default"))) int photosite_peer_imwrite(const char* path, int rows, int cols,
                                                                             int type, void* data, size_t step,
                                                                             const int* params, int nparams) {
  try {
    return cv::imwrite(path, cv::Mat(rows, cols, type, data, step), std::vector<int>(params, params + nparams)) ? 1 : 0;
  } catch (const std::exception&) {
    return 0;
  }
}
