// Private (not installed): scene/street.cpp's one pass over the rows for light_map (scene/lights.cpp),
// and its instruction-set cap and the pole components of plan_street_lighting, for the tests
// that pin them (the same bits on every path; OpenCV's labels).
#pragma once
#include <array>
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <vector>

#include "photosite/image.h"
#include "photosite/scene/night.h"
#include "photosite/scene/street.h"
#include "scene/night_detail.h"

namespace photosite::scene {

// The widest instruction set the street light's row paths (pools, vertical surfaces, façade
// windows) may take: 2 AVX-512 (the AVX2 code compiled for AVX-512VL), 1 AVX2, 0 the scalar
// twins (default 2; the machine's support and PHOTOSITE_SCALAR_LIGHTS=1 cap it). All give the
// same bits; the test runs each. Not thread-safe: set it before a light map, not during one.
void street_light_max_isa(int isa);

// The street lamps' distribution beyond the cut-off as the float paths (pools, vertical light)
// evaluate it at cos γ = c: 16 quartic pieces where their measured relative error is within 10⁻⁶
// (*pieces = true; *max_rel_err: that error), else the 4096-step table (street.cpp, RelTable).
// estrin: the pieces as the vertical light evaluates them (Estrin's scheme), else as the pools
// (Horner's).
float lamp_relative_intensity_float(float c, const ScenePreset& p, bool* pieces = nullptr,
                                    double* max_rel_err = nullptr, bool estrin = false);

// ⌊a[i]/b⌋ for i < n as the façade windows' AVX-512 layout takes its storeys, pitch cells and shop
// units (floor_div8: from a·(1/b), the division itself where that product lies within 8·2⁻⁵³ of
// an integer), for the test that compares them with std::floor(a/b) on every lane. Returns false
// (nothing written) on a machine without AVX-512F and VL.
bool window_floor_div_avx512(const double* a, int n, double b, double* out);

// The day photo's windows on each façade plane (scene/facade_windows.cpp), for add_facade_windows:
// per plane (BuildingFacades::planes, same indices) the columns of its rectified grid (cells of
// kCell_m along it from s0, with the axis tX, tD) that the photo resolves, where its windows replace
// the preset's grid (`used` false: a plane not rectified, unfitted or of too few pixels: the grid
// everywhere on it); per window its plane, its box on the plane (s and Y, m) and the box's bounds
// in the image (pixels, inclusive).
struct FacadeWindowsFound {
  struct Plane {
    bool used = false;
    int samples = 0;  // the pixels find_facade_windows sampled on the plane (every plane's)
    double s0 = 0;
    int ns = 0;
    std::vector<uint8_t> resolved;
  };
  struct Window {
    int plane = -1;
    double s_lo = 0, s_hi = 0, y_lo = 0, y_hi = 0;
    int x0 = 0, x1 = -1, y0 = 0, y1 = -1;
  };
  std::vector<Plane> planes;
  std::vector<Window> windows;
  static constexpr double kCell_m = 0.1;
};
// The 4-connected components of the nonzero cells of a w x h mask (row-major, `mask[j·w + i]`)
// as find_facade_windows reads them: each component's box (left, top, width, height) and its
// cells (area), in the order of the components' first cells in raster order, which is the order of
// OpenCV's labels 1 .. n − 1 (cv::connectedComponentsWithStats(mask, ..., 4, CV_32S): their
// provisional labels are made in raster order and each set takes its smallest), with the same
// statistics (test FacadeWindows.CellComponentsAreOpenCVs). By runs of cells: a run joins the
// runs of the row above that share a column with it.
struct CellComponent {
  int left = 0, top = 0, width = 0, height = 0, area = 0;
};
std::vector<CellComponent> cell_components(const uint8_t* mask, int w, int h);

// tX, tD: each plane's axis along it (add_facade_windows' orientation); zmax: the camera z beyond
// which add_facade_windows draws no window (a pixel's footprint above half a window width).
FacadeWindowsFound find_facade_windows(const ImageF& texture, const ImageF& depth_m, const CameraGeometry& g,
                                       const BuildingFacades& fac, const ScenePreset& p, const double* tX,
                                       const double* tD, double zmax);

// The street light and the façade windows of one frame in one pass over its rows (light_map,
// with geometry and metric depth): per row the light on vertical surfaces and the ground pools
// (add_vertical_street_light and add_street_lighting's pools: both add, on disjoint pixels, the
// pools on ground classes only, the vertical light on none of them), then the windows (a maximum,
// after the added light of the same row), then the lamp heads without a depth test (a maximum
// over small discs: it commutes with the windows'). Per pixel the same operations in the same
// order as the three calls one after the other, so the same bits; a row's labels, depth, façade
// regions, texture and light stay in cache from one part to the next instead of each part
// streaming the whole frame. Returns the heads drawn and the lit windows (the calls' results).
// With `compose` (light_map asked for the night radiance): each row, once its light is final
// (after its windows and its share of the lamp heads), is composed at once (compose->row(y)), while
// it is in cache, instead of in a pass of its own over the finished frame; the lamp heads are
// then drawn row by row inside the pass (the same maxima over the same pixels). compose->lights
// must be L. With `first`: (*first)(y) begins each row, before its street light (light_map's
// retroreflection and vehicle lamps, which then need no pass of their own over the frame), and
// the heads are drawn row by row in the pass as with `compose`.
// With `side` (light_map's vehicle analysis): one thread runs it at the start of the pass while
// the others make the rows outside [side_y0, side_y1], which must not depend on it; the rows
// inside wait until it has returned (one thread: it runs first). An exception from it is
// rethrown after the pass.
struct ComposeRows;
struct StreetRowsResult {
  int pole_lamps = 0, windows = 0;
  // The lamps' shadows on the ground (street_lamps.shadows): (occluder column run, lamp) pairs
  // drawn, and (ground pixel, lamp) pairs whose lamp's light they took off.
  long long shadow_quads = 0, shadow_pixels = 0;
};
// The street lamps' shadows on the ground (street_lamps.shadows; docs/night.md §7): the pixels
// x0 .. x1 − 1 of row y in the shadow of lamp k (its index in StreetLighting::lamps): lamp = k
// without street_lamps.penumbrae (the lamp one point, its centre); with them (n = samples points
// per lamp's disc) lamp = k·(n + 1) + j, in the shadow of the disc's point j, or, j = n, of all
// of them at once (StreetShadowBuilder: an occluder whose shadow's edges move by under half a
// pixel over the disc).
struct ShadowSpan {
  int32_t y, x0, x1, lamp;
};
struct LampShadowRows {
  // Per image row y: spans[row_start[y] .. row_start[y + 1]), sorted by (lamp, x0), disjoint per lamp.
  std::vector<ShadowSpan> spans;
  std::vector<int32_t> row_start;
  long long quads = 0;  // (occluder column run, lamp) pairs drawn
  size_t lamps = 0;     // the lamps they were made for (StreetLighting::lamps.size())
  int samples = 1;      // sample points per lamp's emitting disc (lamp_disc_samples)
  // Span ids per lamp (ShadowSpan::lamp): one point, 1; n points, n + 1 (the last: all of them).
  static int ids_per_lamp(int samples) { return samples == 1 ? 1 : samples + 1; }
  int ids_per_lamp() const { return ids_per_lamp(samples); }
};
// street_lamps.penumbrae (docs/night.md §7): each luminaire's emitting face, a horizontal disc of
// street_lamps.head_diameter_m at the mount height, is taken as this many points of equal area
// (a Vogel spiral, lamp_disc_samples); a ground pixel in the shadow of m of them loses m/n of the
// lamp's term. The layout's half-plane discrepancy (the most a straight shadow edge's share of
// the points differs from its share of the disc's area) is 0.144 at 16 points:
// tests/scene_metric_test.cpp measures it and bounds the shares by it.
constexpr int kLampDiscSamples = 16;
// The kLampDiscSamples points' quadrilaterals of one (occluder run, lamp) with penumbrae: corner i
// of point j's at (u[i][j], v[i][j]) in the image, slope[i][j] = du/dv of its edge (i, i + 1) (0
// along a row; quad_slopes); a point not drawn has v = −1e30 at every corner.
struct DiscQuads {
  static constexpr int kPoints = kLampDiscSamples;
  alignas(32) double u[4][kPoints], v[4][kPoints], slope[4][kPoints];
};
// One occluder run's quadrilateral cast from a point of one lamp (StreetShadowBuilder): its four
// corners P_i (X[i], Y[i], D[i], metres: the run's lowest and highest points at its columns'
// outer edges), the lamp's mount height H_m, its reach (reach_m, reach2_m2 its square), the
// nearest ground in view D_bottom_m (a shadow is cut there), the camera (cx_px, cy_px, f_px, its
// height h_m, its pitch's cosine and sine).
struct QuadCast {
  const double* X;
  const double* D;
  const double* Y;
  double H_m, reach_m, reach2_m2, D_bottom_m;
  double cx_px, cy_px, f_px, h_m, cos_pitch, sin_pitch;
};
// The quadrilateral cast from the point (SX, H, SD): its corners' ground images (the caps in
// scene/street.cpp) projected to (u[i], v[i]); with shift_px, the most a corner moves in the image
// when the point moves by 1 m in the disc's plane (a maximum with *shift_px). False where a corner
// lies behind the camera.
bool cast_quad(const QuadCast& q, double SX, double SD, double* u, double* v, double* shift_px);
// cast_quad from each of the kLampDiscSamples points (SX[j], SD[j]) into q (a point not drawn: the
// v = −1e30 lanes); *vlo, *vhi: the least and largest v of the points drawn. Returns the points
// drawn as bits. The AVX2 form four points to a vector (the same corners; test
// StreetLampShadows.DiscQuadsAreEachPointsOwn); call it only where the machine has AVX2.
unsigned disc_quads_avx2(const QuadCast& in, const double* SX, const double* SD, DiscQuads& q, double* vlo,
                         double* vhi);
unsigned disc_quads_scalar(const QuadCast& in, const double* SX, const double* SD, DiscQuads& q, double* vlo,
                           double* vhi);
// The columns x0 .. x1 − 1 of row y (within 0 .. W − 1) whose pixel centres lie inside the
// quadrilateral (u[i], v[i]) (slope from quad_slopes); false: none (scene/street.cpp).
bool quad_row_span(const double* u, const double* v, const double* slope, int W, int y, int* x0, int* x1);
void quad_slopes(const double* u, const double* v, double* slope);
// quad_row_span of each point's quadrilateral on row y: bit j of the result set where point j has
// columns x0[j] .. x1[j] − 1. The AVX2 form takes four points to a vector (the same columns; test
// StreetLampShadows.DiscRowSpansAreEachPointsOwn); call it only where the machine has AVX2.
unsigned disc_row_spans_avx2(const DiscQuads& q, int W, int y, int32_t* x0, int32_t* x1);
unsigned disc_row_spans_scalar(const DiscQuads& q, int W, int y, int32_t* x0, int32_t* x1);
// The sample points' offsets (ΔX, ΔD) in metres from the disc's centre, n points over a disc of
// diameter_m: r_i = (d/2)·√((i + ½)/n), θ_i = i·π(3 − √5) (Vogel 1979, the golden angle; each
// point stands for an equal area, none at the centre). n = 1: the centre itself, (0, 0).
std::vector<std::array<double, 2>> lamp_disc_samples(double diameter_m, int n);
// The points StreetShadowBuilder takes per lamp under preset p: kLampDiscSamples with
// street_lamps.penumbrae, else 1.
int lamp_shadow_samples(const ScenePreset& p);
// The shadows' spans (scene/street.cpp, where the method is) in steps that several threads share:
// the constructor takes the inputs (kept by reference: they must outlive it), take_blocks() scans
// blocks of columns from a shared counter until none is left, casting each block's runs from one
// lamp after another (a block's lamps taken from its own counter: a thread that finds no block left
// to scan takes the lamps still to cast of the blocks scanned; from any number of threads at once,
// each call on its own thread), finish() merges them once every call has returned. The same spans
// whichever threads take which blocks and lamps. night_scene makes them in its depth stage, beside the low
// beam's rows (a sequence's after it, for its tracked lamps: street_lamp_shadow_spans); the light
// map alone after its plan, from the label runs it makes with the plan.
class StreetShadowBuilder {
 public:
  // `runs`: the label runs of these labels where the caller has them (night_scene's, made beside
  // the Hough stage); else (none, or made of other labels) the constructor makes them
  // (label_runs, over the threads). The scan visits only their solid runs.
  StreetShadowBuilder(const ImageU16& labels, const ImageF& depth_m, const CameraGeometry& g, const StreetLighting& s,
                      const ScenePreset& p, const LabelRuns* runs = nullptr);
  void take_blocks();
  LampShadowRows finish();

 private:
  const ImageU16& labels_;
  const ImageF& depth_;
  const CameraGeometry& g_;
  const StreetLighting& s_;
  std::shared_ptr<const LabelRuns> own_runs_;  // made by the constructor where none were handed
  const LabelRuns* runs_ = nullptr;
  std::vector<double> reach_;
  std::vector<std::array<double, 2>> disc_;  // the lamps' sample points (lamp_disc_samples)
  double disc_radius_ = 0;                    // street_lamps.head_diameter_m / 2
  double D_bottom_ = 0.1;
  std::atomic<int> next_block_{0};
  // Per block of columns: its closed runs (their corners P_i), published (ready) once scanned;
  // its lamps are then cast one by one from next_lamp, by any thread.
  struct CastRun {
    double X[4], D[4], Y[4];
    int x;  // its first column
    bool pole;
  };
  struct BlockRuns {
    std::vector<CastRun> runs;
    std::atomic<bool> ready{false};
    std::atomic<int> next_lamp{0};
  };
  std::unique_ptr<BlockRuns[]> blocks_;
  std::atomic<long long> quads_{0};
  std::mutex parts_mutex_;
  std::vector<std::vector<ShadowSpan>> parts_;
};

// StreetShadowBuilder's spans at once, over the threads (from `runs` where they were made of
// these labels, else from the label runs it makes): the light map where it makes the plan
// itself (light_map), a sequence's tracked lamps (night_scene), add_street_light_rows given none.
LampShadowRows street_lamp_shadow_spans(const ImageU16& labels, const ImageF& depth_m, const CameraGeometry& g,
                                        const StreetLighting& s, const ScenePreset& p,
                                        const LabelRuns* runs = nullptr);

// `shadows`: the lamps' shadow spans of these labels, depth and lamps (StreetShadowBuilder) where
// the caller made them; else, with street_lamps.shadows, made here.
StreetRowsResult add_street_light_rows(ImageF& L, const ImageF& texture, const ImageU16& labels, const ImageF& depth_m,
                                       const CameraGeometry& g, const StreetLighting& s, const ScenePreset& p,
                                       uint64_t seed, const BuildingFacades* facades,
                                       const ComposeRows* compose = nullptr,
                                       const std::function<void(int)>* first = nullptr,
                                       const std::function<void()>* side = nullptr, int side_y0 = 0,
                                       int side_y1 = -1, const LampShadowRows* shadows = nullptr);

// compose() (scene/lights.cpp) one row at a time: the constants once, then any row y on any
// thread writes night's row y from the same rows of texture, lights, labels and beam_lux (the
// same float operations per pixel as compose(), which runs it over the frame).
struct ComposeRows {
  const ImageF& texture;
  const ImageF& lights;
  const ImageU16& labels;
  const ImageF& beam_lux;
  ImageF& night;
  const DarkenParams dp;
  const uint64_t beam_mask;  // beam_lit_class_bits: where compose adds the beam's reflection
  const bool avx2;
  float tbf[3];  // the beam's tint over π per channel
  // With level1 (the lens glare's level 1 of night, sensor/glare.h): level row j is made
  // (glare_level1_row) by whichever thread composes the second of night's rows 2j, 2j + 1 (one
  // row at an odd height's end), counted per pair, and the energy sums of level rows 8b .. 8b + 7
  // (glare_level1_sums) by whichever makes the last of them, counted per batch; any order of the
  // rows gives the same level and sums.
  GlareLevel1* level1 = nullptr;
  // With beam_vertical (the light map's row pass): row(y) first writes the low beam on the row's
  // vertical surfaces into beam_lux (BeamVerticalRows over the same image), then composes.
  const BeamVerticalRows* beam_vertical = nullptr;
  std::unique_ptr<std::atomic<uint8_t>[]> pair_rows;   // night rows composed per level row
  std::unique_ptr<std::atomic<uint8_t>[]> batch_rows;  // level rows made per batch of eight
  ComposeRows(const ImageF& texture, const ImageF& lights, const ImageU16& labels, const ImageF& beam_lux,
              const ScenePreset& p, ImageF& night, GlareLevel1* level1 = nullptr);
  void row(int y) const;
};

// Whether light_map with the metric geometry makes each row in its one row pass from the start
// (its retroreflection and vehicle lamps begin the row, and with_radiance composes it at the end:
// on, the default) or in the separate steps that define it (the retroreflection over the frame,
// the vehicle lamps, the street rows, the lamp heads after them, no LightMap::composed): the same
// bits, which the test compares. Not thread-safe: set it before a light map, not during one.
void light_map_fused_rows(bool on);

// The ground pools' cut-off signature at adaptive samples (scene/street.cpp, street_lamps.
// interp_tolerance): at ground X_m a lamp (its X, its dz² along the road and H² of its height,
// floats as the pool kernel keeps them) is beyond its cut-off γ_c when H² < cos²γ_c·(dx² + dz² + H²),
// in double (cc2 = cos²γ_c).
bool beyond_cutoff(double X_m, double lamp_X_m, float dz2_m2, float H2_m2, double cc2);
// On a ground row whose column x lies at X = (x − c_x)·k_x (k_x > 0), the columns [lo, hi) of
// x0..x1 where that lamp is within its cone (not beyond_cutoff; lo == hi: none), found from its
// knee |X − X_l| = sqrt((H·tan γ_c)² − dz²) and checked against the predicate at the run's ends:
// beyond_cutoff at column x is exactly x < lo || x ≥ hi (the test compares every column).
void cutoff_columns(double lamp_X_m, float dz2_m2, float H2_m2, double cc2, double cx_px, double kx, int x0, int x1,
                    int* lo, int* hi);

// A connected component's bounding box (inclusive pixel bounds).
struct PoleBox {
  int x0, y0, x1, y1;
};
// The 8-connected components of the pole pixels (Label::Pole or Label::PoleGroup) of a label
// image, as bounding boxes, in the order cv::connectedComponents(mask, cc, 8) numbers them: by
// the first 2x2 block (on the even grid, in raster order of the blocks) holding a pixel of the
// component. Found from the rows' runs of pole pixels (union-find over the runs), without a
// mask image or a labelling of the whole frame.
// From the label image's runs (night_detail.h label_runs) when `runs` were made of `labels`, else
// by scanning the image: the same boxes.
std::vector<PoleBox> pole_components(const ImageU16& labels, const LabelRuns* runs = nullptr);
// pole_components of a label image, with the image it was made of (pole_components_of,
// scene/night_detail.h): plan_street_lighting_with takes the boxes for those labels only.
struct PoleComponents {
  LabelsMadeOf labels;
  std::vector<PoleBox> boxes;
};

}  // namespace photosite::scene
