// The day-to-night scene translation (after Baek 2020, "Road Scene Image Translation from Day to
// Night using Semantic Segmentation"), in radiometric units. Each stage is a pure function:
//   linearize → darken (per-class reflectance under night illuminance, W·sr⁻¹·m⁻²)
//   → lanes → edges → lines → vanishing point → coarse depth → light map → compose.
// Stages 3-6 (lanes..vanishing) run on a working copy at most `work_max_width` wide; their
// results are scaled back to full resolution. docs/night.md has the equations and sources.
#pragma once
#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "photosite/device_image.h"
#include "photosite/image.h"
#include "photosite/io.h"
#include "photosite/scene/labels.h"
#include "photosite/scene/scene_preset.h"

namespace photosite {
struct GlareLevel1;  // include/photosite/sensor/glare.h
}

namespace photosite::scene {

struct SequenceState;   // scene/luminaires.h
struct StreetLighting;  // scene/street.h
struct RoadAhead;       // scene/road_line.h
struct SunBlockSums;    // scene/texture_detail.h

// ---- linearize --------------------------------------------------------------------------
// Day image → linear sRGB (3 channels). Integer files are sRGB-decoded (IEC 61966-2-1); float
// files (EXR) are taken as linear. Grey images are replicated, alpha dropped.
ImageF linearize(const ImageF& day, const ImageFileInfo& info);
// The 4097-entry sRGB-decode table linearize() interpolates (shared with the Vulkan kernel).
const std::vector<float>& srgb_decode_table();
// Pass 1 of reflectance_texture (its class sums of Y and pixel counts, per fixed chunk of the
// frame) made by linearize_with_texture_sums in the same pass as the linearisation: each block
// of pixels is summed right after it is linearised, from cache, instead of in a second pass over
// the 24 MB linear image. `image` and `labels` name what the sums are of: reflectance_texture
// takes them only for that image and label map (else it sums itself). The same additions in the
// same order either way, so the same texture to the bit.
// The day photo's white balance (reflectance.day_white_balance, scene/darken.cpp): per-channel
// gains on its linear sRGB, taken with the box basis (the texture's box RGB is M·diag(gain)·s), and
// what was decided. With "road": the mean linear colour m of the road's pixels (every 4th row and
// column, those with all channels inside (0, 1): a clipped or black sample has lost its colour)
// is moved, in the plane (ln m_R/m_G, ln m_B/m_G), to the nearest point of the CIE daylight locus
// (4000-25000 K), green kept: the camera's green or magenta cast out, the daylight's own colour
// (sun, or the sky's blue in the shade) kept.
struct DayBalance {
  enum class Use {
    Off,       // the preset's choice (day_white_balance = "none"): gains 1
    Road,      // the gains below, from the road
    Fallback,  // the road not used (under kDayBalanceMinSamples samples, or its colour too far off the
               // locus to be a cast; `why` says which): gains 1
  };
  Use use = Use::Off;
  std::string why;  // Fallback's reason
  std::array<double, 3> gain{1.0, 1.0, 1.0};
  long samples = 0;                    // the road samples the mean was taken over
  std::array<double, 3> road_mean{};   // their mean linear sRGB
  double road_cct_K = 0;               // the daylight the road's colour was moved to (0: none)
  // The header's text (photosite/night/day_white_balance): "road", "none", or "none: " and why.
  std::string state() const { return use == Use::Road ? "road" : use == Use::Off ? "none" : "none: " + why; }
};
// Fewer road samples than this (100 samples: 1,600 road pixels at the 4×4 spacing) leave the
// photo as it is: the mean of a sliver of road says little about the camera.
inline constexpr long kDayBalanceMinSamples = 100;
// Gains whose largest is more than this times their smallest are not taken as a camera cast: a
// red bus lane or a sodium-lit road, not the camera (photosite choice; Cityscapes' measured cast
// needs 1.42, docs/night.md §1).
inline constexpr double kDayBalanceMaxSpread = 2.0;
// The CIE daylight phase at cct_K (CIE 015:2018: 4000-25000 K) as (ln R/G, ln B/G) of its linear
// sRGB, and the point of the locus (4000-25000 K) nearest to q in that plane: (ln R/G, ln B/G,
// its CCT in K); found on a polyline of the locus, then refined on the curve by Newton's method.
std::array<double, 2> daylight_log_ratios(double cct_K);
std::array<double, 3> nearest_daylight(const std::array<double, 2>& q);
DayBalance day_white_balance(const ImageF& day_linear_srgb, const ImageU16& labels, const ScenePreset& p);

struct TextureSums {
  std::vector<std::array<double, 2 * kLabelCount>> part;  // per chunk: sums of Y, then counts
  DayBalance balance;  // the day photo's white balance the sums were made with
  // Set when `balance` is a sequence's carried one (the `carried` argument below), not this frame's
  // own: the texture then takes the sums only if its own carried balance has the same gains.
  bool balance_carried = false;
  const float* image = nullptr;
  const uint16_t* labels = nullptr;
  // The sun/shade split's block sums (its phase 1) of the block rows that lie in one chunk, made
  // from the same Y in the same pass when asked (`split` below); null otherwise.
  std::shared_ptr<const SunBlockSums> sun;
};
// linearize(), and with it the texture's class sums over `labels` (the frame's size) into
// `sums`; other label sizes or channel counts than RGB: linearize() alone (sums left empty).
// With `split` (the scene preset) the sums are made with its day white balance (sums->balance,
// day_white_balance of the linear image, found from the day image's road before the pass) and,
// its sun/shade split on, also the split's block sums (sums->sun). Without it: no balance.
// `carried` (with `split`'s day_white_balance = "road"): a sequence's white balance, fixed by an
// earlier frame (ClassMeans::balance once balance_set): the sums are made with it and this frame's
// own is not looked for (sums->balance_carried), so that the texture, which takes the carried
// gains, does not sum the frame again (batch --sequence: its reader keeps the group's balance).
ImageF linearize_with_texture_sums(const ImageF& day, const ImageFileInfo& info, const ImageU16& labels,
                                   TextureSums* sums, const ScenePreset* split = nullptr,
                                   const DayBalance* carried = nullptr);
// The refusal of a day image with NaN or Inf at pixel `index` (reading order), naming the file.
[[noreturn]] void fail_damaged_pixel(const ImageF& day, const ImageFileInfo& info, int64_t index);
// ---- sky seen through tree crowns ----------------------------------------------------------
// Cityscapes and KITTI label a tree crown as one polygon, so the sky between its leaves and around
// its edge is labelled vegetation (docs/night.md §1, "Sky through the crowns"). take_sky_gaps
// finds those pixels: vegetation whose day luminance (linear sRGB, Rec. 709 weights) is at least
// p.sky_gap_fraction of the median over the labelled sky, and which joins the labelled sky
// through such pixels (8-neighbours). It labels them Sky in labels.ids and lists them in
// labels.sky_gaps, so every stage after it (texture, darkening, depth, light map, the Vulkan
// kernels) sees sky there; restore_sky_gaps gives the file's ids back. None where the fraction is
// 0, the frame has under 64 sky pixels, or its sky's median is 0. The result is the connected
// closure, independent of the order pixels are visited in. Returns how many were taken.
size_t take_sky_gaps(LabelMap& labels, const ImageF& linear_srgb_day, const ScenePreset& p);
// The same before the linearisation, from the day file's pixels as linearize() decodes them (the
// same pixels as from its result): an 8-bit sRGB file's interleaved codes through its 256
// decodes, or read_image()'s RGB samples with their file info. Other channel counts: none taken,
// and labels.sky_gaps_taken stays false (night_scene takes them from the linear image).
size_t take_sky_gaps(LabelMap& labels, const ImageU8& srgb8_codes, const ScenePreset& p);
size_t take_sky_gaps(LabelMap& labels, const ImageF& day, const ImageFileInfo& info, const ScenePreset& p);
void restore_sky_gaps(LabelMap& labels);
// The linearisation as the chain runs it (prepare_night, batch, bench night): the sky seen through
// tree crowns taken into `labels` first, unless labels.sky_gaps_taken says they were (take_sky_gaps
// from `codes` when given and not empty, else from `day` as linearize decodes it), then linearize_codes_with_texture_sums or
// linearize_with_texture_sums (with `split` and `carried`) over the taken labels. Where the gaps
// could be taken only from the linear image (a grey image), they are taken after the pass and
// *sums is emptied where any were (the texture then makes its own). restore_sky_gaps gives the
// file's ids back.
ImageF linearize_taking_sky_gaps(const ImageF& day, const ImageU8* codes, const ImageFileInfo& info, LabelMap& labels,
                                 TextureSums* sums, const ScenePreset& split, const DayBalance* carried = nullptr);
// The crown's edge pixels that stay vegetation hold leaves and sky in one pixel: a vegetation
// pixel beside the sky (labels.sky_fringe: 8-neighbours, the sky as take_sky_gaps left it) of day
// luminance Y is taken as a linear mix of sky and leaves, Y = f·Y_sky + (1 − f)·Y_leaf
// (labels.sky_day_luminance and labels.leaf_day_luminance; Y_leaf = 0 where the latter is 0), so a
// share f = clamp((Y − Y_leaf) / (Y_sky − Y_leaf), 0, 1) of sky, and its texture (the
// reflectance texture f_k, W/lm) is scaled down where needed so that its luminance factor
// Σ_k K_k f_k is at most (1 − f) of the vegetation's reflectance ρ: the leaf's share, never a
// sky-bright leaf. (The sky's share, f times the night sky's radiance, is left out: at most
// 0.6 × 0.02 cd/m².) None where labels.sky_day_luminance is 0. Returns how many were scaled.
size_t unmix_sky_fringe(ImageF& texture, const ImageF& linear_srgb_day, const LabelMap& labels, const ScenePreset& p);
// Gives the file's ids back when it goes out of scope (also on an exception).
class SkyGapsRestore {
 public:
  explicit SkyGapsRestore(LabelMap& labels) : labels_(labels) {}
  ~SkyGapsRestore() { restore_sky_gaps(labels_); }
  SkyGapsRestore(const SkyGapsRestore&) = delete;
  SkyGapsRestore& operator=(const SkyGapsRestore&) = delete;

 private:
  LabelMap& labels_;
};
// Linear sRGB → photosite's box RGB basis (sensor/spectrum.h).
ImageF linear_srgb_to_box_rgb(const ImageF& linear_srgb);

// ---- darken -----------------------------------------------------------------------------
// Representative reflectance of a class (Table 1 of Baek 2020; unlabeled: mean of the others).
double class_reflectance(int label_id, const ScenePreset& p);
// The bound of a class's band reflectance in the texture: reflectance.diffuse_max for diffuse
// classes (ground, buildings, walls, fences, vegetation, terrain, persons: energy conservation,
// ρ ≤ 1), reflectance.glint_max for specular and retroreflective ones (vehicles, signs, traffic
// lights, poles, guard rails), the sky and the unlabelled classes.
double class_reflectance_max(int label_id, const ScenePreset& p);
// The diffuse (Lambertian) classes: road, sidewalk, parking, ground, rail track, building, wall,
// fence, bridge, tunnel, vegetation, terrain, person, rider.
bool diffuse_class(int label_id);
// Per-pixel reflectance texture f (W/lm, per band): the day image normalised so that the
// luminance-weighted mean of each class equals the class reflectance ρ:
//   f_k(x) = ρ_class · c_k(x) / mean_class(Y(c)),  Y(c) = Σ_k K_k c_k  (band efficacies, lm/W),
// c the day pixel in the box basis, each band capped at class_reflectance_max / Σ_k K_k.
// A Lambertian surface under illuminance E (lx) with relative spectral tint t then has
//   L_k = f_k · t_k · E / π    (W·sr⁻¹·m⁻²),  with luminance ρ·E/π for the class mean.
// Takes linear sRGB and converts to the box basis on the fly.
// `carried` (a sequence's state, scene/luminaires.h SequenceState): the class means to normalise
// by, so that a surface keeps its reflectance from frame to frame of a sequence (the mean over the
// visible part of a class changes as the view moves). A class with a carried mean > 0 takes it; a
// class without one takes this frame's mean, which is recorded when the class covers at least
// kClassMeanMinShare of the frame (below that, a sliver at a border, it is not fixed yet).
// Null: this frame's means (a single frame).
inline constexpr double kClassMeanMinShare = 1e-3;
// The day photo's white balance is carried the same way: the first frame that has one
// (balance_set) fixes the gains for the sequence, so that the colours do not change with the view.
struct ClassMeans {
  std::array<double, kLabelCount> mean{};
  DayBalance balance;
  bool balance_set = false;
};
ImageF reflectance_texture(const ImageF& day_linear_srgb, const ImageU16& labels, const ScenePreset& p,
                           ClassMeans* carried = nullptr);
// Relative tint of a CCT in the box basis, luminance-preserving for a D65-white surface.
std::array<double, 3> illuminant_tint(double cct_K);
// The street lamps' colour, by the scene's lamps.streetlamp_type (one dispatch for every place it
// is used): the RGB radiance of a lamp face of a luminance (cd/m²) — led: the camera's metamer of
// CIE LED-B at lamps.streetlamp_cct_K (lamp_camera_rgb), blackbody_rgb at that CCT without a
// camera; hps: the camera's metamer of HP1, spectrum::hp1_rgb without one — and the relative tint
// of their light on a surface (as illuminant_tint) — led: LED-B's metamer at street.cct_K,
// illuminant_tint(street.cct_K) without a camera; hps: HP1's — over D65's Planck proxy at 6504 K,
// per band, both per cd/m² (photometric for a metamer, box luminance for the proxies).
std::array<double, 3> streetlamp_rgb(const ScenePreset& p, double luminance_cd_m2);
std::array<double, 3> streetlamp_tint(const ScenePreset& p);
// A named lamp spectrum's colour per cd/m² as the run's camera records it
// (ScenePreset::lamp_camera_rgb, set by the night chain), or nullptr where it is not set (a scene
// made without a camera: the callers' fallbacks).
const std::array<double, 3>* lamp_camera_rgb(const ScenePreset& p, spectrum::LampSpectrum s);
// The per-pixel darkening, shared by darken() and compose(): the ambient night illuminance (moon
// and sky glow) per unit reflectance on every surface but the sky (E/π in lx·sr⁻¹ per band: times
// the texture in W·lm⁻¹ it gives W·sr⁻¹·m⁻²; the street lamps add their light in the light map),
// and the sky's glow colour scaled by the pixel's relative luminance. ground_class: the ground
// classes, read by compose (the low beam lights them).
struct DarkenParams {
  float ambient[3];
  double K[3];     // band luminous efficacies (lm/W)
  double rho_sky;  // the sky class reflectance the texture was normalised to
  double glow[3];  // sky glow radiance of relative luminance 1
  bool ground_class[kLabelCount];
};
// The per-pixel darkening itself, darken_pixel(), is private to the library (scene/darken_detail.h):
// its maths is written once, in kernels/common/darken.glsl, for the CPU path and the kernel.
DarkenParams darken_params(const ScenePreset& p);
// Ambient (moon + sky glow) and street lighting on every class; the sky gets its own luminance.
ImageF darken(const ImageF& texture, const ImageU16& labels, const ScenePreset& p);

// ---- geometry (working resolution) -------------------------------------------------------
struct WorkImages {
  double scale = 1.0;  // work = full · scale
  ImageF luma;         // sRGB-encoded luminance [0,1] of the day image
  ImageU16 labels;     // nearest-neighbour labels
};
WorkImages make_work_images(const ImageF& day_linear_srgb, const ImageU16& labels,
                            int work_max_width);
// Lane markings inside the road class (255 = marking): Gaussian blur, then Batista et al.'s
// horizontal contrast accumulation (brighter than both neighbours at the perspective-scaled
// marking width) plus a vertical pass for transverse markings.
ImageU8 lane_markings(const ImageF& luma, const ImageU16& labels, const ScenePreset& p);
// Canny over the segmentation of the selected classes (road, vehicles) plus lane markings.
ImageU8 segmentation_edges(const ImageU16& labels, const ImageU8& lanes, const ScenePreset& p);
struct Segment { float x0, y0, x1, y1; };
// HoughLinesP, dropping near-horizontal/near-vertical lines and lines within the outer border.
// With `labels` (the edges' own size), also lines that run along the frame's own car or the
// rectification's edges: most of their points within 3 px of an ego-vehicle, rectification-border
// or out-of-ROI pixel (scene/lines.cpp).
std::vector<Segment> detect_lines(const ImageU8& edges, const ScenePreset& p, const ImageU16* labels = nullptr);

enum class VpMethod { Hough, RoadPrior, GroundPrior, SkyPrior, ImageCentre };
const char* vp_method_name(VpMethod m);
struct VanishingPoint {
  double x = 0, y = 0;       // pixels of the image the lines came from
  double confidence = 0;     // 0..1
  VpMethod method = VpMethod::ImageCentre;
  int support = 0;           // intersections in the winning cluster
  std::string note;          // why a fallback was taken
};
// Pairwise intersections, densest cluster, its mean; else a prior from the labels.
VanishingPoint vanishing_point(const std::vector<Segment>& lines, const ImageU16& labels,
                               const ScenePreset& p);
// 0 at the vanishing point rising linearly to 1 at the image border along every ray. Used only
// as the traffic signs' beam-illuminance proxy (light_map); depth.Z is metric_depth().
ImageF coarse_depth(int width, int height, double vp_x, double vp_y);

// ---- metric geometry (full resolution) ------------------------------------------------------
// Road coordinates: X right, Y up from the road, D forward along the road (horizontal), metres;
// the camera's optical centre at (0, mount_height_m, 0), pitched down by pitch_rad, no roll or yaw.
// Camera z (depth.Z, the EXR convention: distance along the optical axis) of a point is
//   z = (h − Y)·sin θ + D·cos θ,  y_c = (h − Y)·cos θ − D·sin θ,  u = c_x + f·X/z, v = c_y + f·y_c/z.
// The horizon (D → ∞) is the row y_h = c_y − f·tan θ.
inline constexpr float kDepthInfinity_m = 65504.f;  // sky: the largest finite half (EXR depth.Z is half)
struct CameraGeometry {
  std::string rig;
  double f_px = 1, cx_px = 0, cy_px = 0, mount_height_m = 1, pitch_rad = 0;
  double horizon_y = 0;
  std::string horizon_source = "rig";  // "vanishing_point" or "rig"
  double horizon_confidence = 0;        // the VP's confidence, or 0 for the rig's nominal pitch
  // Why the geometry may not be this camera's, in words ("" when nothing was found): a frame of
  // no rig's aspect ratio taken as a crop, a confident vanishing point the pitch gate refused,
  // a horizon below the frame. The console prints it; the EXR header keeps it.
  std::string note;
  // Ground point of a pixel (Y = 0): false above the horizon. Flat-ground model:
  //   z = f·h / ((v − y_h)·cos θ).
  bool ground_point(double u, double v, double* X, double* D, double* z) const;
  // Camera z of the ground at row v (infinite at and above the horizon).
  double ground_depth_m(double v) const;
  // Camera z of a vertical plane D = D_plane, fronto-parallel, at row v.
  double plane_depth_m(double v, double D_plane) const;
  // Projection of a road-coordinate point; false behind the camera (z <= 0.05 m).
  bool project(double X, double Y, double D, double* u, double* v, double* z) const;
};
// Tram rails among the lane markings. A polished rail head reads as a bright line in the day
// photo and lane_markings takes it for one, but a rail is steel, not retroreflecting paint: a
// marking component (8-connected, at the working resolution `work_scale` of the frame that g
// describes) that runs straight along the ground (X = a + b·D fitted to its pixels' ground points:
// at least 3 m long, |b| ≤ 0.3, RMS residual ≤ 0.15 m) and has a partner doing the same at one of
// the preset's rail gauges (geometry.tram_gauges_m) plus a head's width over at least 3 m of road
// where both are seen (the two lines' separation at both ends of that stretch within 0.15 m of it:
// the metric scene's 10 % on the ground, issue 14 §1, over 1.5 m) is a rail:
// its pixels are cleared from `lanes_work` and, with `rails`, set to 255 in it (a working-size
// mask made here). Returns the number of pixels cleared. The markings still lead the vanishing
// point (rails run along the road too); only the light map's retroreflection and the low beam's
// markings read the cleared mask, and the texture under the rails (texture_under_rails).
int drop_tram_rails(ImageU8& lanes_work, double work_scale, const CameraGeometry& g, const ScenePreset& p,
                    ImageU8* rails = nullptr);
// The reflectance texture under tram rails (a frame-size mask, nonzero on the rails): a rail
// head's day brightness is the sky mirrored in polished steel, not a diffuse albedo, and its
// diffuse reflectance is not known, so photosite gives it the ground it is set in: per row, each
// run of rail pixels and a window on each side as wide as a rail's top on the ground at that row
// (0.12 m: a grooved rail's head, groove and guard are about 0.11 m, EN 14811 Ri60) plus 2 px of
// blur take the mean texture of the 3 pixels just beyond each window (of the run's label, off the
// mask; the two sides' means averaged, one side where the image border or another label leaves
// the other none; unchanged where neither). Returns the number of pixels changed.
int texture_under_rails(ImageF& texture, const ImageU16& labels, const ImageU8& rails, const CameraGeometry& g);
// The rig's intrinsics at width x height, the horizon from the vanishing point when it is a
// Hough estimate (confidence >= 0.3) whose pitch atan((c_y − y_vp)/f) is within
// rig.pitch_tolerance_deg (1.6° by default, derived in rig.cpp) of the rig's nominal pitch, else
// from the rig's nominal pitch (horizon_source "rig", confidence 0).
CameraGeometry camera_geometry(const CameraRig& rig, int width, int height, const VanishingPoint& vp);
// Metric depth (m): ground classes (and ego vehicle, rectification border, out of ROI) by the
// flat-ground model; every object — an instance, or a 4-connected region of one non-ground
// class — a vertical plane at the depth of its ground contact: vehicles, people and instances
// one fronto-parallel plane at the region's lowest row; other regions (buildings, walls,
// vegetation, poles) per column at that column's lowest pixel of the region (a façade receding
// along the street). A contact that is hidden (occluded bottom) is taken where the region's
// visible bottom is: an approximation that places it farther. Sky kDepthInfinity_m; depths
// capped at max_depth_m elsewhere.
// `facades`: building_facades(labels.ids, g, max_depth_m) when the caller has it (night_scene
// computes it once for depth, windows and the street light on façades), else computed here.
ImageF metric_depth(const LabelMap& labels, const CameraGeometry& g, double max_depth_m,
                    const struct BuildingFacades* facades = nullptr);

// Building façades as vertical planes (geometry.cpp). A building region (4-connected region of
// the building class) is cut into up to kMaxFacadePlanes façades, each the vertical plane
//   n_X·X + n_D·D = d_m   (road coordinates, (n_X, n_D) a unit normal pointing away from the
//   camera, d_m >= 0 the plane's distance from the camera's foot),
// fitted to the region's unoccluded ground contacts: columns whose lowest building pixel sits
// directly on a ground class (not on a car, vegetation, a fence). A vertical plane meets the flat
// ground in a straight line, whose image is a straight line v = a + b·u; it is fitted in the image
// by RANSAC over deterministic pairs of contacts (inlier band ±kFacadeInlier_px: the contact row
// is quantised to ±0.5 px, the labels' boundary to about ±1 px), refitted by least squares on the
// inliers; further façades (each with at least kMinFacadeContacts and 15% of the contacts) are
// fitted to the contacts the first ones leave out — a further line within 3 bands of an earlier
// façade's foot line (mean over its inliers) is that façade's noisier contacts and joins it.
// Every column of the
// region takes the façade of its nearest inlier contact, also where cars or trees hide the foot.
// A column whose own building pixels reach below that façade's foot line (by more than the
// inlier band) is something nearer (a building's projecting part): it keeps the per-column depth
// of metric_depth's vertical-plane model. A region with fewer than kMinFacadeContacts contacts on
// one line is fitted alike to the feet of the objects in front of it (the bottom of the stack of
// objects below each column), the nearest the hidden foot can be, a lower bound on its depth
// (`occluded`; one plane per region, as lines of lower bounds do not tell a corner from the things
// in front): first stacks of fixed structures only (fences, walls, hedges), then also through
// vehicles and people; with none of those either, it keeps the per-column depth
// and gets an unfitted plane for its window layout only: along
// the road (n = (±1, 0)) when the median ground point of its columns lies more than 3 m to the
// side, else facing the camera (n = (0, 1)) — a named approximation, the orientation of the old
// per-pixel rule.
inline constexpr int kMaxFacadePlanes = 3, kMinFacadeContacts = 8;
inline constexpr double kFacadeInlier_px = 1.5;
struct FacadePlane {
  double nX = 0, nD = 1, d_m = 0;
  double line_a = 0, line_b = 0;  // the foot line in the image: v = a + b·u (fitted planes)
  int inliers = 0;                // contacts within the band (0 for an unfitted plane)
  bool fitted = false;
  bool occluded = false;          // fitted to the feet of the objects in front (no contact showed)
};
struct BuildingFacades {
  ImageI32 region;                  // per pixel: index into `regions`, -1 off the building class
  std::vector<FacadePlane> planes;  // every region's façades
  struct Region {
    int x0 = 0, contacts = 0;        // first column; unoccluded ground contacts found
    std::vector<int> column_plane;   // per column from x0: index into `planes` (-1: column has no pixel)
    std::vector<uint8_t> on_plane;   // per column: 1 when its depth is the plane's
  };
  std::vector<Region> regions;
  // The façade plane of pixel (x, y), or nullptr off buildings.
  const FacadePlane* plane_at(int x, int y, bool* on_plane = nullptr) const;
  // plane_at's lookup as an index into `planes` (-1: none), for the rows that hold a row's region
  // ids (reg = region.row(y)) at hand: column x of region r (r >= 0, x in its columns), and of a
  // pixel whose region is not known to be one (-1 off buildings).
  int plane_of_region(int r, int x) const {
    const Region& R = regions[r];
    return R.column_plane[x - R.x0];
  }
  int plane_index(const int32_t* reg, int x) const { return reg[x] < 0 ? -1 : plane_of_region(reg[x], x); }
};
BuildingFacades building_facades(const ImageU16& ids, const CameraGeometry& g, double max_depth_m);
// Camera z where the pixel ray through (u, v) meets the vertical plane; INFINITY when it does not
// (parallel or behind the camera).
double facade_depth_m(const CameraGeometry& g, const FacadePlane& f, double u, double v);

// ---- lights and composition (full resolution) ----------------------------------------------
// Ego low beam (stage 6b): one headlamp's luminous intensity (cd) from the scene preset's
// [ego_beam] table at horizontal angle h_deg (positive right) and vertical angle v_deg (positive
// up): bilinear in the table, 0 above the cut-off and outside the table.
double low_beam_intensity_cd(double h_deg, double v_deg, const ScenePreset& p);
// Illuminance (lx) of the headlamp pair on the road at road coordinates (X_m right, D_m forward):
// E = Σ_lamps I(h, v)·cos θ / d², θ the incidence from the road's normal, d the lamp distance.
double low_beam_lux(double X_m, double D_m, const ScenePreset& p);
// Illuminance (lx) of the headlamp pair on a sign at road coordinates (X_m right, Y_m above the
// road, D_m forward), on the plane perpendicular to each ray (R_A's E⊥): Σ_lamps I(h, v)/d², with
// the table below the cut-off and the preset's beam_above_cutoff_cd above it (within the table's
// horizontal range). What lights traffic signs with the metric geometry.
double sign_beam_lux(double X_m, double Y_m, double D_m, const ScenePreset& p);
// A sign's coefficient of retroreflection at observation angle alpha_deg (cd·lx⁻¹·m⁻²): sign_RA at
// sign_RA_alpha_deg and below, ∝ α^−sign_RA_alpha_exponent up to sign_RA_alpha_max_deg, held beyond.
double sign_RA_at(double alpha_deg, const ScenePreset& p);
// The same at entrance angle entrance_deg (the lamp's ray against the sign's normal): sign_RA_at(α)
// times the preset's entrance factor (ScenePreset::sign_RA_entrance_deg; 1 where it is empty).
double sign_RA_at(double alpha_deg, double entrance_deg, const ScenePreset& p);
// The sign's retroreflected luminance toward the camera (cd/m²) at road point (X_m, Y_m, D_m), the
// camera on the car's centre line camera_height_m up: Σ_lamps R_A(α_lamp)·E⊥_lamp, α_lamp the
// angle at the sign between the lamp and the camera, and (where the preset has an entrance table) at
// the entrance angle β_lamp of the lamp's ray on a sign facing along the road: its normal toward the
// camera's heading, (0, 0, −1), so tan β = √((x_lamp − X)² + (y_lamp − Y)²) / D.
double sign_retroreflected_cd_m2(double X_m, double Y_m, double D_m, double camera_height_m, const ScenePreset& p);
// The same for a sign on the road ahead `road`: where it was measured curved, the sign faces the
// traffic that reads it (else as above), its normal −(sin ψ, 0, cos ψ), ψ =
// sign_facing_heading_rad(road, X_m, D_m, p.sign_read_distance_m), so tan β = |l × n|/(l·n) for the
// ray l toward each lamp; a lamp behind the sign's face lights nothing that returns, and a sign
// whose back the camera sees returns 0. What the light map evaluates per sign pixel.
double sign_retroreflected_cd_m2(double X_m, double Y_m, double D_m, double camera_height_m, const ScenePreset& p,
                                 const RoadAhead& road);
// The heading ψ (rad from +D, positive toward +X) that a sign at ground point (X_m, D_m) faces along
// (its normal −(sin ψ, 0, cos ψ)): on a road ahead measured curved, the course of the traffic that
// reads it read_distance_m before it: the camera's heading (0) turned by the bend between the
// curve's start and that point (0 where the point lies before the start, ±90° beyond the quarter
// turn; the sign's arc length taken from its angle about the arc's centre; scene/
// sign_retro_detail.h, SignFacing); 0 unless road.curved.
double sign_facing_heading_rad(const RoadAhead& road, double X_m, double D_m, double read_distance_m);
// The same E evaluated in float (IEEE binary32, Cephes' atanf): what low_beam_illuminance stores,
// bit for bit. Within a few 2⁻²⁴ relative of low_beam_lux plus the table's slope times the
// angles' float error; may differ between lit and 0 within that error of the cut-off line or the
// table's edge (the bound and the band: tests/scene_metric_test.cpp).
float low_beam_lux_f32(double X_m, double D_m, const ScenePreset& p);
// E_beam per pixel (1 channel, lx): low_beam_lux_f32 at each pixel's flat-ground point
// (CameraGeometry::ground_point), 0 at and above the horizon. What compose() reads.
// labels given: computed only where it is read, on ground-class pixels (compose, and the light
// map's retroreflection on the lane markings, which lie on road and parking pixels:
// lane_markings marks only those); 0 elsewhere.
ImageF low_beam_illuminance(const CameraGeometry& g, int width, int height, const ScenePreset& p,
                            const ImageU16* labels = nullptr);
// One headlamp's share of low_beam_lux_f32 (lamp 0 on the left, x_l = −spacing/2; 1 on the
// right): the same bits as the pair's E where the other lamp gives 0.
float low_beam_lamp_lux_f32(double X_m, double D_m, int lamp, const ScenePreset& p);
// Shadows of the low beam on the ground (docs/night.md §6c): a shadow map per lamp from the metric
// scene (the points of beam_vertical_classes' pixels with a finite depth, below the lamps'
// height, at their direction from the lamp, keeping the nearest forward distance D per cell of
// kBeamShadowCellPx (2) image pixels); each lit ground pixel of beam_lux (the ground classes,
// low_beam_illuminance's) whose flat-ground point lies farther than the nearest solid
// point in its cell (by one cell's margin: 1/D_solid > 1/D + cell/h_l) loses that lamp's share:
// it keeps the other lamp's (low_beam_lamp_lux_f32's bits), 0 in both lamps' shadows; every
// other pixel keeps its value. The same image for any thread count. Returns the pixels in each
// lamp's shadow alone and in both (those the hidden lamp did not light included).
struct BeamShadowStats {
  long long one_lamp[2] = {0, 0}, both = 0;
};
BeamShadowStats shade_low_beam_ground(ImageF& beam_lux, const CameraGeometry& g, const ImageU16& labels,
                                      const ImageF& depth_m, const ScenePreset& p);
// The low beam on vertical surfaces (scene/lights.cpp): the illuminance (lx) of the headlamp pair
// on a surface element at road point (X_m, Y_m, D_m) with unit normal (nX, nY, nD) toward the
// side it is seen from, Σ_lamps I(h, v)·cos β / max(d², (5·lens_diameter_m)²) with the table below
// the cut-off and beam_above_cutoff_cd above it (within the table's horizontal range), 0 on a face
// turned away; a tree crown (crown = true, n the unit vector to the camera) as a Lambert sphere,
// I(h, v)·Φ(α)/d². The double reference of add_low_beam_vertical's float evaluation.
double low_beam_vertical_lux(double X_m, double Y_m, double D_m, double nX, double nY, double nD, bool crown,
                             const ScenePreset& p);
// The classes the beam lights as vertical surfaces: every class but the ground classes (their
// light is low_beam_illuminance's), the sky, the camera car, the border and out-of-ROI classes and
// traffic signs (their beam light is their retroreflection, in the light map).
const std::array<bool, kLabelCount>& beam_vertical_classes();
// The classes whose pixels compose() lights with beam_lux, as bits by class id: the ground classes
// and beam_vertical_classes.
uint64_t beam_lit_class_bits();
// Writes into beam_lux (low_beam_illuminance's image) the low beam's E on every pixel of
// beam_vertical_classes: low_beam_vertical_lux's float evaluation at the pixel's point (depth_m,
// camera z; the point from the camera geometry), the normal that of its façade plane (facades;
// buildings) or turned to the camera (a crown's: the unit vector to the camera); 0 where the
// depth is not finite and positive. Lane markings included: the ground's E that
// low_beam_illuminance gives a marking pixel (for the light map's retroreflection, read before)
// is replaced on these classes, so that compose() lights a vertical surface by this rule alone.
// Other pixels keep their value. compose() reads it on those classes as on the ground.
void add_low_beam_vertical(ImageF& beam_lux, const CameraGeometry& g, const ImageU16& labels, const ImageF& depth_m,
                           const BuildingFacades* facades, const ScenePreset& p);

struct LightStats {
  int signals = 0, vehicle_lamps = 0, pole_lamps = 0, windows = 0;
  // Street lighting (scene/street.cpp): luminaires placed ("poles" or "road_edges"), the peak
  // luminous intensity that makes the EN 13201 average hold, and the road's average luminance and
  // overall uniformity U0 = L_min / L_avg on the calculation grid.
  int vehicles_in_traffic = 0, vehicles_parked = 0, vehicles_parked_lit = 0;
  // Vehicles whose low beams light the ground ahead of them (vehicle_lamps.beams_on_road): oncoming
  // ones (vehicle_beams, toward the camera) and those going away (vehicle_beams_going_away).
  int vehicle_beams = 0, vehicle_beams_going_away = 0;
  int street_lamps = 0;
  // The street lamps' shadows on the ground (street_lamps.shadows): (ground pixel, lamp) pairs
  // whose lamp's light an occluder takes off (docs/night.md §7).
  long long street_shadow_pixels = 0;
  std::string street_lamp_source = "none";
  std::string street_lamp_note;  // why none were placed (StreetLighting::note); empty when there are lamps
  double street_peak_intensity_cd = 0, road_luminance_avg_cd_m2 = 0, road_uniformity_u0 = 0;
  // The road ahead from the kerbs (StreetLighting::road_ahead, measure_road_ahead): "curved",
  // "straight" or why not measured; the arc's curvature (1/m, + toward +X; 0 unless curved), where
  // it starts (m along the road from the camera), and the curvature's standard error.
  std::string road_ahead = "not measured";
  double road_curvature_per_m = 0, road_curve_start_m = 0, road_curvature_se_per_m = 0;
};
struct LightMap {
  ImageF radiance;  // W·sr⁻¹·m⁻², emitted + retroreflected (the lens's glare comes later, in the sensor)
  // With `with_radiance`, where the light map has its row pass (geometry, depth_m and beam_lux
  // given): the night radiance compose(texture, radiance, labels, *beam_lux, p), the same bits,
  // each row composed inside that pass once its light is final. Empty otherwise (compose it then).
  ImageF composed;
  // With `composed` and `with_glare_level1`: the lens glare's level 1 of `composed` (its 2x2 box
  // and row energies, glare_level1_row), each level row made in the row pass as soon as its two
  // rows are composed, while they are in cache; the sensor's glare then starts from it
  // (mean_signal_electrons, expose) instead of reading the full-resolution frame again.
  std::shared_ptr<GlareLevel1> glare_level1;
  LightStats stats;
};
// `geometry` and `depth_m` (metric_depth) null: the image-space light map without street-lamp
// pools; with them lamps, pools and windows are placed and sized in metres. `depth` is the
// coarse ramp (coarse_depth), the sign-illuminance proxy of the image-space map only (with
// `geometry` and `depth_m` signs get sign_beam_lux at their metric point: the ramp runs to the image border and moved
// with the view). `street` (a sequence's luminaires, scene/luminaires.h): the street lighting to
// use; null: plan_street_lighting of this frame. `beam_lux` (low_beam_illuminance)
// lights the lane markings (R_L·E; its E is the ground classes', so a marking on another class
// stays dark, as lane_markings marks none there); null: markings stay dark.
LightMap light_map(const ImageF& day_linear_srgb, const ImageF& texture, const LabelMap& labels,
                   const ImageU8& lanes, const ImageF& depth, const VanishingPoint& vp,
                   const ScenePreset& p, uint64_t seed, const CameraGeometry* geometry = nullptr,
                   const ImageF* depth_m = nullptr, const ImageF* beam_lux = nullptr,
                   const BuildingFacades* facades = nullptr, const StreetLighting* street = nullptr,
                   bool with_radiance = false, bool with_glare_level1 = false);
// The night radiance: the darkened texture (darken_pixel, computed on the fly rather than read
// back from a darkened image: one pass over memory less) + diffuse low-beam light on ground
// classes, f·t·E/π with E = beam_lux (low_beam_illuminance, lx, 1 channel) + the light map.
ImageF compose(const ImageF& texture, const ImageF& lights, const ImageU16& labels,
               const ImageF& beam_lux, const ScenePreset& p);

// ---- the chain ----------------------------------------------------------------------------
// A stage's wall time, and the process CPU time it took (with one thread: its own work, which
// other processes on a loaded machine do not stretch as they do the wall time).
struct StageTiming { std::string stage; double ms; double cpu_ms = 0; };
double process_cpu_ms();  // CLOCK_PROCESS_CPUTIME_ID in ms
struct NightScene {
  ImageF darkened;  // full resolution, kept only with keep_darkened
  ImageF lights, radiance;  // full resolution
  ImageF depth;             // metres (metric_depth), full resolution
  ImageF beam_input;        // coarse_depth ramp: the sign-illuminance proxy of light_map, full resolution
  ImageF beam_lux;          // ego low-beam illuminance on the ground (lx, low_beam_illuminance): what compose() reads
  CameraGeometry geometry;
  ImageU8 lanes_work, edges_work;            // working resolution
  double work_scale = 1;
  int tram_rail_pixels = 0;  // working-resolution marking pixels taken for tram rails (drop_tram_rails)
  size_t sky_gap_pixels = 0;  // vegetation pixels the scene took for sky (take_sky_gaps)
  size_t sky_fringe_pixels = 0;  // crown-edge pixels whose texture unmix_sky_fringe scaled down
  // The day levels the crowns were read against (LabelMap::sky_day_luminance, leaf_day_luminance:
  // medians of linear sRGB Rec. 709 Y; 0 where none).
  float sky_day_luminance = 0, leaf_day_luminance = 0;
  BeamShadowStats beam_shadow;  // ground pixels in the low beam's shadows (shade_low_beam_ground)
  // Vertical-surface pixels in its shadows (below the cut-off's top, docs/night.md §6c), counted
  // as the ground's: each lamp's alone and both.
  BeamShadowStats beam_shadow_vertical;
  std::vector<Segment> lines_work;
  VanishingPoint vp;  // full-resolution pixels
  LightStats light_stats;
  DayBalance day_balance;  // the day photo's white balance the texture was made with
  std::vector<StageTiming> timings;
  DeviceImage resident_radiance;  // PixelTail::resident: `radiance` is still on the device
  // The lens glare's level 1 of `radiance` (LightMap::glare_level1) where night_scene was asked
  // for it and its light map composed the radiance; else null (the sensor makes it then).
  std::shared_ptr<const GlareLevel1> glare_level1;
};
// The full-resolution per-pixel tail of night_scene() (per-class darkening, low beam and
// composition, from the reflectance texture, the light map and the low beam's illuminance) as a
// backend returns it: SensorRunner::night_tail (include/photosite/backend.h), on Vulkan
// gpu::SceneStages::tail. Geometry stays on the CPU.
struct PixelTail {
  ImageF radiance;    // compose()
  ImageF darkened;    // darken(), only when asked for
  DeviceImage resident;  // non-empty: `radiance` is also left on the backend's device, for the
                         // sensor to read from there
};
// The chain on the CPU. To run its per-pixel tail where a backend runs (on Vulkan the radiance
// then stays on the device for the sensor): night_scene(..., SensorRunner&) in
// include/photosite/backend.h.
// `sequence` (scene/luminaires.h): the state carried from the previous frames of a sequence, its
// `pose` set for this frame; updated here. With it the frame keeps the sequence's reflectance
// normalisation, camera pitch and street luminaires (issue 14 §3); null: a single frame, inferred
// from what it shows alone.
// `sums`: linearize_with_texture_sums' class sums of this frame (else the texture makes them).
// `glare_level1`: make the lens glare's level 1 inside the compose pass (NightScene::glare_level1),
// for a sensor whose lens has glare.
NightScene night_scene(const ImageF& day_linear_srgb, const LabelMap& labels, const ScenePreset& p,
                       uint64_t seed, bool keep_darkened = false, SequenceState* sequence = nullptr,
                       const TextureSums* sums = nullptr, bool glare_level1 = false);

// ---- synthetic test scenes -----------------------------------------------------------------
struct SyntheticOptions {
  int width = 640, height = 320;
  double vp_x = 320, vp_y = 130;
  int cars = 2;
  bool lanes = true, road = true, buildings = true, sky = true;
};
struct SyntheticScene {
  ImageF day_linear_srgb;
  LabelMap labels;  // labelIds plus instances for the cars
};
// A straight road in perspective toward (vp_x, vp_y) with dashed lane markings, sky, buildings
// on both sides and box cars on the road. Deterministic.
SyntheticScene make_synthetic_road(const SyntheticOptions& o);

// A scene rendered from a known camera by ray casting (one ray per pixel centre): a flat road
// (Y = 0) with a 1 m texture checker, lane markings (dashes 3 m on / 6 m off at X = ±lane_width/2,
// solid lines 0.2 m inside the road edges), sidewalks, building façades 12 m tall beyond them
// (3 to 200 m ahead), terrain beyond, sky above the horizon, and boxes standing on the road (front
// face at D, sides visible, labelled car with instances, or with another label: vegetation for
// a hedge, no instance). A box with base_m > 0 floats from base_m to height_m above the road (a
// tree's crown, its trunk a box of its own), its underside visible from below. A box with
// yaw_rad != 0 is turned about its front face's centre (X_m, D_m): its length runs along
// (sin yaw, cos yaw) in (X, D), as a camera's heading (a car following a bend).
struct SyntheticBox {
  double X_m, D_m, width_m, height_m, length_m;
  Label label = Label::Car;
  double base_m = 0;
  double yaw_rad = 0;
};
struct SyntheticCameraOptions {
  int width = 1024, height = 512;
  CameraGeometry camera;  // intrinsics and pose at width x height
  double road_half_width_m = 7, lane_width_m = 3.5, sidewalk_m = 3;
  // The lane lines (at X = ±lane_width_m/2, 0.15 m wide): dashes dash_m long every dash_period_m
  // along the road, from D = 0 (RMS-1's built-up Leitlinie by default: 3 m dash, 6 m gap).
  double dash_m = 3, dash_period_m = 9;
  std::vector<SyntheticBox> boxes;
  // Windows in the façades' day texture (window_pitch_m 0: plain façades): dark glass (0.04
  // against the wall's 0.25) in boxes window_width_m wide centred at D = window_phase_m + k·pitch
  // along the road, window_height_m tall from window_sill_m + j·window_storey_m up.
  double window_pitch_m = 0, window_width_m = 1.2, window_phase_m = 0;
  double window_storey_m = 3.4, window_height_m = 1.6, window_sill_m = 0.9;
  // Tram rails set in the road (none by default): a polished head rail_head_m wide, of day value
  // 0.5 against the asphalt's 0.08, centred at each X (a track: two rails gauge + head apart).
  std::vector<double> rail_X_m;
  double rail_head_m = 0.065;
  // Where the camera stands in the street (the coordinates above: X across, D along): its foot at
  // (world_X_m, world_D_m), its heading turned by world_yaw_rad toward +X (CameraPose's
  // convention, scene/street.h). 0: at the street's origin, looking along it. The depth and the
  // labels are the camera's as ever.
  double world_X_m = 0, world_D_m = 0, world_yaw_rad = 0;
  // A curving street (0: straight, the default, the same bits as before it): straight along X = 0
  // up to D = curve_start_D_m, then its centre line follows a circle of radius |road_radius_m|
  // turning toward +X (positive) or −X (negative), tangent to the straight there. The road, its
  // lane and edge lines (dashes counted by arc length), sidewalks, rails and façades (the same
  // offsets across the centre line, the façades as cylinders about the circle's centre, from 3 to
  // 200 m of arc length) follow it; the boxes and the ground's check texture stay in (X, D). Only a
  // radius beyond the façades' offset (road + sidewalk) makes sense; the arc runs at most a half turn.
  double road_radius_m = 0, curve_start_D_m = 0;
};
// A ground point (X, D) of the street of `o` in the street's own coordinates: *e_m its signed
// offset across the centre line (+ toward +X where the street is straight; on the curve, the
// distance from the circle's centre taken the same way) and *a_m its arc length along it (= D on
// the straight). The straight street (road_radius_m 0): (X, D).
void synthetic_street_coordinates(const SyntheticCameraOptions& o, double X_m, double D_m, double* e_m, double* a_m);
struct SyntheticCameraScene {
  ImageF day_linear_srgb;
  LabelMap labels;
  ImageF depth_m;     // true camera z (kDepthInfinity_m for sky)
  ImageU8 box_front;  // 1: pixel on a box's front face
};
SyntheticCameraScene make_synthetic_camera_scene(const SyntheticCameraOptions& o);

}  // namespace photosite::scene
