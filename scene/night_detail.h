// Private (not installed): night_scene() with its full-resolution per-pixel tail handed to a
// backend. The public faces are scene::night_scene() (the CPU) and night_scene(..., SensorRunner&)
// (include/photosite/backend.h, core/backend.cpp); the Vulkan tests hand it a gpu::SceneStages
// of their own context.
#pragma once
#include <functional>
#include <memory>
#include <utility>
#include <vector>

#include "photosite/scene/night.h"

namespace photosite::scene {

// The label image a part made ahead of its stage was made of (metric_depth_runs,
// building_regions, pole_components_of below): its buffers and size. The stage takes the part
// only for the same labels: the same buffers (night_scene hands every stage its one LabelMap;
// comparing addresses costs nothing) of the same size; else it makes its own.
struct LabelsMadeOf {
  const uint16_t* ids = nullptr;
  const uint16_t* instances = nullptr;  // null: made without instance ids (or not reading them)
  int width = 0, height = 0;
  LabelsMadeOf() = default;  // of no labels: never the same (a part once taken)
  explicit LabelsMadeOf(const ImageU16& label_ids, const ImageU16* instance_ids = nullptr)
      : ids(label_ids.data()),
        instances(instance_ids && !instance_ids->empty() ? instance_ids->data() : nullptr),
        width(label_ids.width()),
        height(label_ids.height()) {}
  explicit LabelsMadeOf(const LabelMap& lm) : LabelsMadeOf(lm.ids, &lm.instances) {}
  bool same_labels(const LabelsMadeOf& at_hand) const {
    return ids && ids == at_hand.ids && instances == at_hand.instances && width == at_hand.width &&
           height == at_hand.height;
  }
};

using NightTail = std::function<PixelTail(const ImageF& texture, ImageF& lights, const ImageU16& labels,
                                          const ImageF& beam_lux, const ScenePreset& p, bool keep_darkened)>;
// An empty tail: the CPU path (darken before the geometry, compose at the end).
NightScene night_scene_with(const ImageF& day_linear_srgb, const LabelMap& labels, const ScenePreset& p,
                            uint64_t seed, bool keep_darkened, const NightTail& tail,
                            SequenceState* sequence = nullptr, const TextureSums* sums = nullptr,
                            bool glare_level1 = false);
// The lane-marking mask at the frame's resolution (the labels' size): the working-resolution mask
// read at the pixel centres (nearest), cleared wherever the frame's label is not road or parking
// (a working pixel's block of frame pixels reaches past the road's labels at their border; the
// lane stage finds markings on those two classes only). What the light map and the low beam read
// (night_scene_with; `bench night` times the light map alone on it).
ImageU8 lanes_at_frame(const ImageU8& lanes_work, const ImageU16& labels);
// metric_depth's part that reads only the labels (the object pixels' label-run components, their
// extents and per-column lowest rows; scene/geometry.cpp), so that night_scene makes it beside
// the Hough stage, before the vanishing point and the camera geometry exist; metric_depth_with
// takes it for the labels it was made of (else makes it): the same depth.
// The label image's runs of one id per row (run_end, scene/runs_detail.h), scanned once for the
// three labels-only parts below (metric_depth_runs, building_regions, pole_components_of), which
// otherwise scan the 4 MB image each; each takes it when made of its labels (`ids`), else scans
// itself: the same runs either way. Row y's runs are row_start[y] .. row_start[y + 1] - 1; run i
// covers [x0[i], end(i)) and holds label id[i].
struct LabelRuns {
  LabelsMadeOf labels;
  int width = 0;
  std::vector<int> x0;
  std::vector<uint16_t> id;
  std::vector<int> row_start;
  int end(int i, int y) const { return i + 1 < row_start[y + 1] ? x0[i + 1] : width; }
  bool made_of(const ImageU16& ids) const { return labels.same_labels(LabelsMadeOf(ids)); }
};
std::shared_ptr<const LabelRuns> label_runs(const ImageU16& ids);
// shade_low_beam_ground (photosite/scene/night.h) reading the solid classes' columns from the
// label runs `runs` where they were made of these labels (night_scene's, made beside the Hough
// stage), else from the labels: the same image.
BeamShadowStats shade_low_beam_ground_with(ImageF& beam_lux, const CameraGeometry& g, const ImageU16& labels,
                                           const ImageF& depth_m, const ScenePreset& p, const LabelRuns* runs);
// shade_low_beam_ground_with in its two steps (scene/lights.cpp): the constructor makes each
// lamp's shadow map of the solid points (labels and metric depth only, of a width x height frame;
// nothing of the beam image), shade() then takes the lamps' shares off the beam image's lit
// ground pixels in those maps' shadows: the same image and counts as shade_low_beam_ground_with
// (which is these two steps), at any thread count. night_scene makes the maps in its depth stage,
// beside the low beam's rows, and shades once the beam image is whole.
class GroundShadowMaps {
 public:
  GroundShadowMaps(int width, int height, const CameraGeometry& g, const ImageU16& labels, const ImageF& depth_m,
                   const ScenePreset& p, const LabelRuns* runs);
  ~GroundShadowMaps();
  BeamShadowStats shade(ImageF& beam_lux) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};
struct MetricDepthRuns;
std::shared_ptr<const MetricDepthRuns> metric_depth_runs(const LabelMap& labels, const LabelRuns* runs = nullptr);
ImageF metric_depth_with(const LabelMap& labels, const CameraGeometry& g, double max_depth_m,
                         const BuildingFacades* facades, const MetricDepthRuns* runs);
// building_facades' part that reads only the labels (the building class's label runs, their
// 4-connected regions and the regions' columns' lowest rows; scene/geometry.cpp), so that
// night_scene makes it beside the Hough stage with metric_depth_runs; building_facades_with takes
// it (moving its regions out; it then writes the region image from its runs) when it was made of
// these labels `ids`, else makes it: the same façades.
struct BuildingRegions;
std::shared_ptr<BuildingRegions> building_regions(const ImageU16& ids, const LabelRuns* runs = nullptr);
BuildingFacades building_facades_with(const ImageU16& ids, const CameraGeometry& g, double max_depth_m,
                                      BuildingRegions* regions);
// plan_street_lighting's part that reads only the labels (its poles' 8-connected components,
// pole_components in scene/street_detail.h), so that night_scene makes it beside the edges stage
// (OpenCV's Canny), long before the camera geometry the plan needs exists;
// plan_street_lighting_with takes it when it was made of these labels (lm.ids), else makes it:
// the same plan.
struct PoleComponents;
std::shared_ptr<const PoleComponents> pole_components_of(const ImageU16& ids, const LabelRuns* runs = nullptr);
StreetLighting plan_street_lighting_with(const LabelMap& labels, const CameraGeometry& g, const ScenePreset& p,
                                         uint64_t seed, const PoleComponents* poles);
// The vehicle lamps' parts that read only the labels, the instance ids and the day image
// (scene/lights.cpp), none the vanishing point or the camera geometry, so that night_scene makes
// them ahead: vehicle_rows_part the rows holding vehicle pixels (beside Canny), then
// add_vehicle_parts the vehicles' components (instances, or the vehicle classes' 8-connected
// components), their boxes and their colour cues (CIELAB red and white cues, red blobs per
// vehicle; beside the Hough transform; it makes the rows again if `parts` was made of other
// labels). light_map_with takes what `vehicles` holds when it was made of these labels (lm.ids
// and lm.instances; the cues: and of this day image), else makes it: the same components, boxes,
// cues and lamps. light_map() is light_map_with(..., nullptr). With beam_vertical (over *beam_lux)
// and the night radiance composed in the row pass (LightMap::composed not empty), each row's low
// beam on vertical surfaces is written just before the row is composed; otherwise it is not
// touched (the caller runs add_low_beam_vertical before composing).
struct VehicleParts;
class BeamVerticalRows;
std::shared_ptr<VehicleParts> vehicle_rows_part(const LabelMap& labels);
void add_vehicle_parts(VehicleParts& parts, const ImageF& day_linear_srgb, const LabelMap& labels);
struct LampShadowRows;  // scene/street_detail.h
class ParkedSet;        // scene/luminaires.h: a sequence's parked vehicles (their parking lights' draws)
LightMap light_map_with(const ImageF& day_linear_srgb, const ImageF& texture, const LabelMap& labels,
                        const ImageU8& lanes, const ImageF& depth, const VanishingPoint& vp, const ScenePreset& p,
                        uint64_t seed, const CameraGeometry* geometry, const ImageF* depth_m, const ImageF* beam_lux,
                        const BuildingFacades* facades, const StreetLighting* street, bool with_radiance,
                        bool with_glare_level1, const VehicleParts* vehicles,
                        const BeamVerticalRows* beam_vertical = nullptr,
                        const LampShadowRows* street_shadows = nullptr, ParkedSet* parked = nullptr);
// add_low_beam_vertical (scene/lights.cpp) row by row: the set-up once, then row(y) writes the
// vertical surfaces' beam E of row y into beam_lux (the same values as add_low_beam_vertical's),
// from any thread. The light map's row pass runs it just before it composes the row (ComposeRows),
// so that the row's labels, depth and beam are read while in cache, not in a pass of their own:
// after the row's retroreflection, which reads the ground's E on the lane markings (road and
// parking pixels in the chain, lanes_at_frame; a mask given to the light map directly may mark a
// pixel of a vertical class, whose E, 0 in the ground's image, this then replaces).
class BeamVerticalRows {
 public:
  // shadows: the lamps' shadows on these surfaces (docs/night.md §6c, "Shadows of the low beam");
  // false: the rule alone (the tests' comparison with its double reference).
  BeamVerticalRows(ImageF& beam_lux, const CameraGeometry& g, const ImageU16& labels, const ImageF& depth_m,
                   const BuildingFacades* facades, const ScenePreset& p, bool shadows = true);
  ~BeamVerticalRows();
  void row(int y) const;
  // The E of pixel (x, y) of a lit vertical class from lamp 0 (left) or 1 (right) alone, without
  // shadows: the same bits as that lamp's term of the rule's sum (0 where the rule lights nothing).
  float lamp_lux(int x, int y, int lamp) const;
  // The pixels the rows run so far shaded (shadows on): from the left lamp only (one_lamp[0]), the
  // right only, both; as the ground's counts, those whose hidden lamp gave no light included
  // (their value unchanged). All 0 without shadows. The same for any thread count.
  BeamShadowStats shadow_stats() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};
// coarse_depth row by row (scene/vanishing.cpp): its column terms made once, then any row y of a
// width x height image `d` written by row(d, y), the same values as coarse_depth's, from any
// thread (night_scene's depth halves share its rows, each taking the next ones once its own work
// is done).
struct CoarseDepthRows {
  CoarseDepthRows(int width, int height, double vp_x, double vp_y);
  void row(ImageF& d, int y) const;
  int width, height;

 private:
  std::vector<double> txs;
  double vy_, top, bottom;
};
// low_beam_illuminance row by row (scene/lights.cpp): its set-up once (the beam's table, the
// columns' x_n), then any row y of a width x height image `E` written by row(E, y), the same values
// as low_beam_illuminance's (which is these rows over the frame), from any thread. The labels are
// read when a row is made (night_scene's depth halves share the rows).
class LowBeamRows {
 public:
  LowBeamRows(const CameraGeometry& g, int width, int height, const ScenePreset& p, const ImageU16* labels);
  ~LowBeamRows();
  void row(ImageF& E, int y) const;
  // The columns [first, second) of row y that the AVX2 rows evaluate without their lit test (every
  // lamp surely lit there, no arctangent reduced: beam_sure_span in scene/lights.cpp); {0, 0}
  // where none (at and above the horizon, without a table). For the tests.
  std::pair<int, int> sure_columns(int y) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};
// The widest instruction set low_beam_illuminance's rows may take (scene/lights.cpp): 2 AVX-512,
// 1 AVX2, 0 the scalar loop (default 2; the machine's support and PHOTOSITE_SCALAR_LIGHTS cap
// it); the light map's sign pixels lit by the beam: eight at a time at 2, else one by one. All give
// the same bits; the tests run each.
void beam_max_isa(int isa);

}  // namespace photosite::scene
