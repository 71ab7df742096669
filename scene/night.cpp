// The whole day-to-night chain with per-stage timings (thesis Table 6 counterpart).
#include <time.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <exception>
#include <functional>
#include <optional>
#include <thread>
#include <vector>
#include <omp.h>
#if defined(__x86_64__)
#include <immintrin.h>
#endif

#include "photosite/scene/luminaires.h"
#include "photosite/scene/night.h"
#include "scene/lanes_detail.h"
#include "scene/night_detail.h"
#include "scene/street_detail.h"
#include "scene/texture_detail.h"

namespace photosite::scene {

ImageU8 lanes_at_frame(const ImageU8& lanes_work, const ImageU16& labels) {
  const int W = labels.width(), H = labels.height();
  ImageU8 full(W, H, 1, uninitialized);
  const int ww = lanes_work.width(), wh = lanes_work.height();
  std::vector<int> sx(W), sy(H);
  for (int x = 0; x < W; ++x) sx[x] = std::min(ww - 1, static_cast<int>((x + 0.5) * ww / W));
  for (int y = 0; y < H; ++y) sy[y] = std::min(wh - 1, static_cast<int>((y + 0.5) * wh / H));
  // sx is non-decreasing: the frame columns that read working column j are [x0[j], x0[j + 1]).
  std::vector<int> x0(ww + 1);
  for (int j = 0, x = 0; j <= ww; ++j) {
    while (x < W && sx[x] < j) ++x;
    x0[j] = x;
  }
  // Where every column reads working column x/2 (the exact doubling, W = 2·ww), a row is each
  // working byte written twice: sixteen bytes at a time by interleaving a vector with itself.
  bool doubling = W == 2 * ww;
  for (int x = 0; x < W && doubling; ++x) doubling = sx[x] == x / 2;
  const uint16_t road = static_cast<uint16_t>(Label::Road), parking = static_cast<uint16_t>(Label::Parking);
  // sy is non-decreasing: the rows that read one working row are consecutive; the first of
  // them is filled and copied to the others, then their marked pixels are cleared off the road.
#pragma omp parallel for schedule(static)
  for (int y = 0; y < H; ++y) {
    if (y > 0 && sy[y] == sy[y - 1]) continue;
    int y_end = y + 1;
    while (y_end < H && sy[y_end] == sy[y]) ++y_end;
    const uint8_t* src = lanes_work.row(sy[y]);
    uint8_t* dst = full.row(y);
    int x = 0;
    unsigned marked = 0;  // whether the row holds a marking (most rows hold none)
    if (doubling) {
#if defined(__x86_64__)
      __m128i seen = _mm_setzero_si128();
      for (; x + 32 <= W; x += 32) {
        const __m128i v = _mm_loadu_si128(reinterpret_cast<const __m128i*>(src + x / 2));
        seen = _mm_or_si128(seen, v);
        _mm_storeu_si128(reinterpret_cast<__m128i*>(dst + x), _mm_unpacklo_epi8(v, v));
        _mm_storeu_si128(reinterpret_cast<__m128i*>(dst + x + 16), _mm_unpackhi_epi8(v, v));
      }
      marked = _mm_movemask_epi8(_mm_cmpeq_epi8(seen, _mm_setzero_si128())) != 0xffff;
#endif
      for (; x < W; ++x) marked |= dst[x] = src[x / 2];
    }
    for (; x < W; ++x) marked |= dst[x] = src[sx[x]];
    for (int z = y + 1; z < y_end; ++z) std::copy_n(dst, W, full.row(z));
    if (!marked) continue;
    // Markings are paint on the carriageway: the lane stage finds them on road and parking pixels
    // only (lane_row), and the Cityscapes classes put every painted marking there ("road":
    // "including the markings on the road", bicycle lanes and parking spaces delimited by markings
    // alone; "parking": parking lots and driveways; a sidewalk is delimited from the road by a
    // kerb, not by markings, and "rail track" is track that cars cannot drive on; cityscapes-
    // dataset.com, class definitions). A working pixel's block of frame pixels can reach past the
    // road's labels at their border (a kerb, a car's or a person's outline, a sign over the road):
    // those pixels are no marking, and the markings' retroreflection (docs/night.md §7) and the
    // beam's marking rules must not reach them. The marked working pixels are few (under 1.3 % of
    // the shared Cityscapes frames'): a marked working row is scanned eight bytes at a time and
    // only the blocks of its marked pixels read the labels.
    for (int k = 0; k < ww; k += 8) {
      const int n = std::min(8, ww - k);
      if (n == 8) {
        uint64_t any;
        std::memcpy(&any, src + k, 8);
        if (!any) continue;
      }
      for (int j = k; j < k + n; ++j) {
        if (!src[j]) continue;
        for (int z = y; z < y_end; ++z) {
          uint8_t* d = full.row(z);
          const uint16_t* id = labels.row(z);
          for (int c = x0[j]; c < x0[j + 1]; ++c)
            if (id[c] != road && id[c] != parking) d[c] = 0;
        }
      }
    }
  }
  return full;
}

// Runs `first` on the calling thread and `second` on a second thread where `threads` is 2 (one
// OpenMP team of two: thread 0 is the caller), else one after the other, as where the team asked
// for has one thread (OMP_THREAD_LIMIT=1, or OMP_DYNAMIC under load: the caller then runs both);
// an exception from either is rethrown here. The caller's thread takes the half that allocates
// the images kept after it: glibc gives each thread its own arena, and memory freed in the second
// thread's is not reused by the caller's, so the large buffers stay in the main arena (the peak
// of Memory.Night2048x1024StaysUnderTheDocumentedPeak).
template <class First, class Second>
void side_by_side(int threads, const First& first, const Second& second) {
  if (threads < 2) {
    first();
    second();
    return;
  }
  std::exception_ptr failed[2];
#pragma omp parallel num_threads(2)
  {
    const int i = omp_get_thread_num();
    try {
      if (i == 0) first();
      if (i == 1 || omp_get_num_threads() == 1) second();
    } catch (...) {
      failed[i] = std::current_exception();
    }
  }
  for (const std::exception_ptr& e : failed)
    if (e) std::rethrow_exception(e);
}

// A piece of work that either of side_by_side's two halves may run, once: take() runs it where
// no half has yet (the second half, early), take_or_wait() runs it or waits until the other
// half's run ends (the first half, where it needs the result). Never a wait on a half that has
// not started: with one thread the first half runs whole before the second, and takes it. A run
// that threw counts as ended: the waiting half goes on, and side_by_side rethrows the exception.
class OnceBeside {
 public:
  explicit OnceBeside(std::function<void()> f) : f_(std::move(f)) {}
  void take() {
    int expected = 0;
    if (!state_.compare_exchange_strong(expected, 1, std::memory_order_acq_rel)) return;
    struct Done {  // ended, also where f_ throws
      std::atomic<int>& s;
      ~Done() { s.store(2, std::memory_order_release); }
    } done{state_};
    f_();
  }
  void take_or_wait() {
    take();
    while (state_.load(std::memory_order_acquire) != 2) {
#if defined(__x86_64__)
      _mm_pause();
#else
      std::this_thread::yield();
#endif
    }
  }

 private:
  std::function<void()> f_;
  std::atomic<int> state_{0};  // 0 not taken, 1 running, 2 ended
};

double process_cpu_ms() {
  timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

NightScene night_scene(const ImageF& day, const LabelMap& labels, const ScenePreset& p, uint64_t seed,
                       bool keep_darkened, SequenceState* sequence, const TextureSums* sums, bool glare_level1) {
  return night_scene_with(day, labels, p, seed, keep_darkened, {}, sequence, sums, glare_level1);
}

NightScene night_scene_with(const ImageF& day, const LabelMap& labels_in, const ScenePreset& p,
                            uint64_t seed, bool keep_darkened, const NightTail& tail, SequenceState* seq,
                            const TextureSums* sums, bool glare_level1) {
  NightScene s;
  // Sky seen through tree crowns (take_sky_gaps): the chain's callers (prepare_night, batch) take
  // them from the codes before the linearisation's class sums; a caller that did not, here on a
  // copy of its labels (and then the texture makes its own sums where any were taken).
  std::optional<LabelMap> own;
  if (!labels_in.sky_gaps_taken) {
    own = labels_in;
    if (take_sky_gaps(*own, day, p) > 0) sums = nullptr;
  }
  const LabelMap& labels = own ? *own : labels_in;
  s.sky_gap_pixels = labels.sky_gaps.size();
  s.sky_day_luminance = labels.sky_day_luminance;
  s.leaf_day_luminance = labels.leaf_day_luminance;
  using clock = std::chrono::steady_clock;
  auto t = clock::now();
  double c = process_cpu_ms();
  auto lap = [&](const char* name) {
    const auto now = clock::now();
    const double cn = process_cpu_ms();
    s.timings.push_back({name, std::chrono::duration<double, std::milli>(now - t).count(), cn - c});
    t = now;
    c = cn;
  };
  const int W = day.width(), H = day.height();
  // In the exact-halving case (a 2048-wide frame to the 1024 working width) the lane stage's
  // working luminance is made inside the texture's second pass, while each chunk's day pixels
  // are in cache, instead of in a pass of its own over the frame (its time is in "darken").
  // `sums`: the texture's pass 1, when the linearisation made it (linearize_with_texture_sums).
  const WorkSize ws = work_size(W, H, p.work_max_width);
  ImageF work_luma = ws.halving ? ImageF(ws.width, ws.height, 1, uninitialized) : ImageF();
  ImageF texture = reflectance_texture_with(day, labels.ids, p, seq ? &seq->reflectance : nullptr,
                                                  ws.halving ? &work_luma : nullptr, sums, &s.day_balance);
  // The crown's edge pixels left as vegetation: the leaf's share of the pixel only (unmix_sky_fringe).
  s.sky_fringe_pixels = unmix_sky_fringe(texture, day, labels, p);
  lap("darken");
  WorkImages w = make_work_images_with(day, labels.ids, p.work_max_width, ws.halving ? &work_luma : nullptr);
  s.work_scale = w.scale;
  // The edges' grey rendering of the classes and markings is made row by row with the markings,
  // on both threads (lane_markings_with_grey), rather than on one thread inside the edges' pair.
  ImageU8 grey;
  s.lanes_work = lane_markings_with_grey(w.luma, w.labels, p, &grey);
  lap("lanes");
  // The edges (OpenCV's Canny, barely faster at 2 threads than at 1) on this thread, and beside
  // them on a second one the label image's runs (label_runs: one scan for the three labels-only
  // parts), the street-lamp plan's labels-only part, its poles' components (pole_components_of;
  // the plan itself needs the camera geometry, in the depth stage), and the light map's vehicle
  // rows (vehicle_rows_part: the rows holding vehicle labels or instance ids; a small struct, the
  // vehicles' images are added beside Hough on this thread). Thread CPU times on the bench frame
  // (twenty-second session): Canny 0.83 ms, the runs and poles 0.43, the vehicle rows 0.43; in the
  // twenty-seventh, two runs of 9 chains: Canny 0.55-1.19 ms (medians 0.76 and 1.17), the other
  // half 0.87-0.94 (the runs 0.32, the poles 0.11, the vehicle rows 0.45). At 1
  // thread both in turn (this lap then holds their time, no longer "depth" and "lights").
  std::shared_ptr<const PoleComponents> poles;
  std::shared_ptr<const LabelRuns> label_row_runs;
  std::shared_ptr<VehicleParts> vehicles;
  side_by_side(
      std::min(2, omp_get_max_threads()), [&] { s.edges_work = segmentation_edges_of_grey(grey, p); },
      [&] {
        label_row_runs = label_runs(labels.ids);
        // The poles only where the preset has street lighting: unlit, the plan keeps no lamps (it
        // still measures the road's extent, from the labels alone; scene/luminaires.cpp).
        if (p.street_road_luminance_cd_m2 > 0) poles = pole_components_of(labels.ids, label_row_runs.get());
        vehicles = vehicle_rows_part(labels);
      });
  grey = ImageU8();
  lap("edges");
  // OpenCV's HoughLinesP (serial: its random point order) on a second thread where there are two,
  // and beside it on this one the parts of the metric depth and of the façades that read only the
  // labels (metric_depth_runs, building_regions, from the label runs made beside Canny), the
  // lane mask at the frame's size, and the light map's vehicle components, boxes and colour cues
  // (add_vehicle_parts: labels, instance ids and the day image only; the light map, much later,
  // takes them): nothing else can start before the vanishing point, which needs the lines. Thread
  // CPU times on the bench frame: Hough 2.05 ms; beside it 0.92 ms, then the vehicles' components
  // and boxes 0.64 and cues 0.42 (twenty-seventh session, medians of 9 chains: this half 1.83-1.89
  // ms in all, Hough 2.13-2.15). The vehicle analysis's red lens cue (0.9 ms with its road grey)
  // and its states (they need the geometry) stay in the light map: with the lens cue this half
  // outlasts Hough by more than it saves there (docs/benchmarks.md, "Night chain, twenty-second
  // session: the vehicle analysis beside the Hough transform"). At 1 thread both in turn (this
  // lap then holds their time, no longer "depth" and "lights").
  std::shared_ptr<const MetricDepthRuns> depth_runs;
  std::shared_ptr<BuildingRegions> regions;
  ImageU8 lanes_full;
  side_by_side(
      std::min(2, omp_get_max_threads()),
      [&] {
        depth_runs = metric_depth_runs(labels, label_row_runs.get());
        regions = building_regions(labels.ids, label_row_runs.get());
        lanes_full = lanes_at_frame(s.lanes_work, labels.ids);  // what the light map reads
        add_vehicle_parts(*vehicles, day, labels);
      },
      [&] { s.lines_work = detect_lines(s.edges_work, p, &w.labels); });
  lap("lines");
  VanishingPoint vp = vanishing_point(s.lines_work, w.labels, p);
  // Back to full-resolution pixel coordinates (pixel centres).
  vp.x = (vp.x + 0.5) / w.scale - 0.5;
  vp.y = (vp.y + 0.5) / w.scale - 0.5;
  s.vp = vp;
  lap("vanishing");
  s.geometry = camera_geometry(p.rig.name.empty() ? rig_for_image(W, H) : p.rig, W, H, vp);
  if (seq) {  // the sequence keeps its first frame's pitch (SequenceState::pitch_rad)
    if (std::isnan(seq->pitch_rad)) seq->pitch_rad = s.geometry.pitch_rad;
    else if (seq->pitch_rad != s.geometry.pitch_rad) {
      s.geometry.pitch_rad = seq->pitch_rad;
      s.geometry.horizon_y = s.geometry.cy_px - s.geometry.f_px * std::tan(seq->pitch_rad);
      s.geometry.horizon_source = "sequence";
    }
  }
  // The depth stage's two independent halves side by side, one per thread where there are two:
  // the façade planes (fitted once: depth, windows and the street light on façades read them), the
  // metric depth, whose per-component fits and stack sweep are serial, then the low beam's shadow
  // maps of the vertical surfaces (BeamVerticalRows' set-up) and of the ground (GroundShadowMaps),
  // which read only the labels and the metric depth; and the street-lamp plan
  // (plan_street_lighting: labels and geometry only; the light map is handed it, and a sequence
  // tracks it; its poles made beside the edges, above; `plan` below) and the tram rails' markings. Then both halves
  // share the rows of the ego low beam's image and of the coarse depth. Each half's loops run on
  // its own thread (nested regions get one thread: OpenMP's default), and every function gives
  // the same result for any thread count, so the same bits. Thread CPU times on the bench frame
  // (twenty-seventh session): façades 0.69 ms, depth 1.84, plan 0.09, the two shadow maps' fills
  // with their set-up ~1.2 (at 2 threads, after this stage, they had been 0.35 and 0.40 ms of
  // wall time with merges and block minima on one thread); the rails 0.14; the low beam's rows
  // 3.1 and the coarse depth's 0.4 (docs/benchmarks.md, "Twenty-seventh session").
  BuildingFacades facades;
  std::vector<uint64_t> facade_keys;  // a sequence's (FacadeSet::hold)
  StreetLighting planned;
  // The shared rows go to whichever half is free first, in chunks of 32 rows from a counter per
  // image: each row is written by the same function whichever thread takes it, so the same bits.
  // The low beam's rows read the labels and the geometry only (the ground classes: the lane
  // markings lie on road and parking pixels), so either half may take them at any time.
  s.beam_input = ImageF(W, H, 1, uninitialized, unit::dimensionless);
  s.beam_lux = ImageF(W, H, 1, uninitialized);
  const CoarseDepthRows coarse(W, H, vp.x, vp.y);
  const LowBeamRows beam_rows(s.geometry, W, H, p, &labels.ids);
  std::atomic<int> coarse_next{0}, beam_next{0};
  auto take_rows = [H](std::atomic<int>& next, const auto& row) {
    constexpr int kRows = 32;
    for (int y0; (y0 = next.fetch_add(kRows)) < H;)
      for (int y = y0; y < std::min(H, y0 + kRows); ++y) row(y);
  };
  auto shared_rows = [&] {
    take_rows(beam_next, [&](int y) { beam_rows.row(s.beam_lux, y); });
    take_rows(coarse_next, [&](int y) { coarse.row(s.beam_input, y); });
  };
  // The low beam on vertical surfaces (cars, people, walls, crowns ahead; it needs the metric depth
  // and the façade planes) is written into the beam image row by row in the light map's row pass
  // (below); its set-up, the vertical surfaces' shadow maps, is made here. The ground's shadows
  // (ego_beam.shadows) are taken off the beam image once it is whole, after this stage.
  std::optional<BeamVerticalRows> beam_vertical;
  std::optional<GroundShadowMaps> ground_shadows;
  // The street lamps' shadows on the ground (street_lamps.shadows; a single frame's plan: a
  // sequence's tracked lamps are known only after this stage, and the light map makes them then):
  // their column blocks are taken by both halves once their own work and the shared rows are done
  // (StreetShadowBuilder: the same spans whichever thread takes which block), the first half
  // setting them up after the plan; the second half helps only where they are set up by then.
  std::optional<StreetShadowBuilder> street_shadows;
  std::atomic<bool> street_shadows_ready{false};
  auto street_shadow_blocks = [&] {
    if (street_shadows_ready.load(std::memory_order_acquire)) street_shadows->take_blocks();
  };
  // The street-lamp plan reads the labels and the geometry only: the second half makes it first,
  // beside the façades and the metric depth (its road ahead, measure_road_ahead, took it from
  // 0.1 to ~1 ms, then on the first half's serial path), and the first half, which needs it for
  // the street lamps' shadows, waits for it there; whichever half reaches it first makes it (one
  // thread: the first half, before the second starts), so the same plan either way.
  OnceBeside plan([&] { planned = plan_street_lighting_with(labels, s.geometry, p, seed, poles.get()); });
  side_by_side(
      std::min(2, omp_get_max_threads()),
      [&] {
        facades = building_facades_with(labels.ids, s.geometry, p.max_depth_m, regions.get());
        // A sequence's façades keep the planes they were first fitted with (FacadeSet::hold), for
        // their depth and their windows alike.
        if (seq) facade_keys = seq->facades.hold(&facades.planes, seq->pose, p.max_depth_m);
        s.depth = metric_depth_with(labels, s.geometry, p.max_depth_m, &facades, depth_runs.get());
        plan.take_or_wait();
        if (p.lamp_shadows && !seq && !planned.lamps.empty()) {
          street_shadows.emplace(labels.ids, s.depth, s.geometry, planned, p, label_row_runs.get());
          street_shadows_ready.store(true, std::memory_order_release);
        }
        beam_vertical.emplace(s.beam_lux, s.geometry, labels.ids, s.depth, &facades, p, p.beam_shadows);
        if (p.beam_shadows) ground_shadows.emplace(W, H, s.geometry, labels.ids, s.depth, p, label_row_runs.get());
        shared_rows();
        street_shadow_blocks();
      },
      [&] {
        plan.take();  // (the first half waits for it where it is being made here)
        // Tram rails that the lane stage took for markings (drop_tram_rails: they led the
        // vanishing point with the markings) leave the markings that the light map lights; the
        // frame-size mask is remade only where some were found.
        // Their texture becomes the road's beside them (texture_under_rails; nothing on the
        // other thread reads the texture before the light map).
        ImageU8 rails;
        s.tram_rail_pixels = drop_tram_rails(s.lanes_work, w.scale, s.geometry, p, &rails);
        if (s.tram_rail_pixels > 0) {
          lanes_full = lanes_at_frame(s.lanes_work, labels.ids);
          texture_under_rails(texture, labels.ids, lanes_at_frame(rails, labels.ids), s.geometry);
        }
        shared_rows();
        street_shadow_blocks();
      });
  LampShadowRows street_shadow_rows;
  if (street_shadows) street_shadow_rows = street_shadows->finish();
  street_shadows.reset();
  // The low beam's shadows on the ground (the depth and the beam image both made now): each lamp's
  // share leaves the ground pixels that a solid object hides from it.
  // (ego_beam.shadows = false: none, on the ground or on vertical surfaces.)
  if (ground_shadows) s.beam_shadow = ground_shadows->shade(s.beam_lux);
  ground_shadows.reset();
  depth_runs.reset();
  regions.reset();
  poles.reset();
  // The darkened layer (asked for; a device tail makes its own) from the texture as it is final,
  // after the tram rails' painting above (its time then in "depth").
  if (keep_darkened && !tail) s.darkened = darken(texture, labels.ids, p);
  lap("depth");
  StreetLighting tracked;
  if (seq) {
    tracked = seq->luminaires.update(planned, s.geometry, W, H, seq->pose, p, seed);
    tracked.pose = seq->pose;  // the façade windows laid out in the sequence's world
    tracked.facade_keys = std::move(facade_keys);
    seq->parked.forget(seq->pose, p.max_depth_m);
  }
  // A sequence's street lamps' shadows, for its tracked lamps, from the label runs made beside the
  // Hough stage (street_lamp_shadow_spans over the threads; their time in the light map's stage).
  if (seq && p.lamp_shadows && !tracked.lamps.empty())
    street_shadow_rows = street_lamp_shadow_spans(labels.ids, s.depth, s.geometry, tracked, p, label_row_runs.get());
  label_row_runs.reset();
  // On the CPU the light map composes the night radiance row by row inside its row pass, each row
  // once its light is final (LightMap::composed: the same bits as compose() after it, without a
  // pass of its own over four full-frame images); the stage is then timed as one,
  // "lights+compose". With a tail (the device's compose) the light map alone, then the tail.
  // The low beam on vertical surfaces into the beam image (its set-up made in the depth stage):
  // each row inside the light map's row pass just before the row is composed, while its labels and
  // depth are in cache; where the light map does not compose (a device tail), over the frame
  // before the tail.
  LightMap lm = light_map_with(day, texture, labels, lanes_full, s.beam_input, vp, p, seed, &s.geometry, &s.depth,
                               &s.beam_lux, &facades, seq ? &tracked : &planned, !tail, glare_level1 && !tail,
                               vehicles.get(), &*beam_vertical, street_shadow_rows.lamps ? &street_shadow_rows : nullptr,
                               seq ? &seq->parked : nullptr);
  vehicles.reset();
  if (seq) ++seq->frames;
  s.light_stats = lm.stats;
  if (!lm.composed.empty()) {
    s.beam_shadow_vertical = beam_vertical->shadow_stats();  // its rows ran in the row pass
    s.radiance = std::move(lm.composed);
    s.lights = std::move(lm.radiance);
    s.glare_level1 = std::move(lm.glare_level1);
    lap("lights+compose");
    return s;
  }
#pragma omp parallel for schedule(static, 8)
  for (int y = 0; y < H; ++y) beam_vertical->row(y);
  s.beam_shadow_vertical = beam_vertical->shadow_stats();
  lap("lights");
  if (tail) {
    PixelTail t = tail(texture, lm.radiance, labels.ids, s.beam_lux, p, keep_darkened);
    s.radiance = std::move(t.radiance);
    if (keep_darkened) s.darkened = std::move(t.darkened);
    s.resident_radiance = t.resident;
  } else {
    s.radiance = compose(texture, lm.radiance, labels.ids, s.beam_lux, p);
  }
  s.lights = std::move(lm.radiance);
  lap("compose");
  return s;
}

}  // namespace photosite::scene
