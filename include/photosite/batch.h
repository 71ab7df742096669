// Whole data sets: finding the (image, labels, instances) items of a data set's own layout or a
// manifest, grouping sequence frames, sharding deterministically, and the engine that turns
// them into night frames (run: its queue, resume manifest, shards and fixed-pattern cache).
#pragma once
#include <atomic>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "photosite/backend.h"
#include "photosite/outputs.h"
#include "photosite/scene/ego_motion.h"
#include "photosite/scene/scene_preset.h"

namespace photosite::batch {

enum class Dataset { Cityscapes, Kitti, Bdd100k };
Dataset parse_dataset(const std::string& name);  // bad input on anything else
const char* to_string(Dataset d);

// The camera preset and camera rig (presets/rigs) a data set was recorded with, the defaults of
// `batch --dataset` and of the bundled KITTI sample: Cityscapes onsemi-ar0331 on the "cityscapes"
// rig, KITTI sony-icx267-flea2 (FLIR Flea2) on the "kitti" rig; BDD100K's dashcams vary, so
// onsemi-ar0331 and rig "auto" (chosen per image by aspect ratio, scene/rig.h).
struct DatasetCamera {
  const char* camera;
  const char* rig;
};
DatasetCamera dataset_camera(Dataset d);

struct Item {
  std::string key;          // unique relative path of the output, without extension ('/'-separated)
  std::string image, labels, instances;           // input paths
  std::string labels_rel, instances_rel;          // where the label copies go under --out
  std::string camera;       // the image's own calibration (Cityscapes camera/*.json), or ""
  // The frame's odometry for `batch --sequence` (scene/ego_motion.h), "" where the data set has
  // none: Cityscapes vehicle[_sequence]/<split>/<city>/<stem>_vehicle.json with odometry_time its
  // timestamp[_sequence]/.../<stem>_timestamp.txt; KITTI oxts/<sub>/data/<frame>.txt with
  // odometry_time the drive's oxts/<sub>/timestamps.txt and odometry_line the frame's number.
  std::string odometry, odometry_time;
  long odometry_line = -1;
  // KITTI: the folder of the drive's calibration files (calib/<sub>/, scene/ego_motion.h
  // read_kitti_camera_mount) for the camera's place on the vehicle, or "" (the OXTS unit's place).
  std::string odometry_calib;
  // A manifest line's own odometry (its time_s, speed_m_s, yaw_rate_rad_s and camera_* fields;
  // read_manifest), with `odometry` then naming the line ("list.txt:3") for messages.
  std::optional<scene::OdometrySample> odometry_given;
  std::string origin;       // where the item is listed ("list.txt:3"), for messages; "" for a layout

  std::string label_format = "auto";
  std::string group;        // sequence id: frames of one group share device, seed and frame count
  int frame = 0;            // frame number within the group (consecutive from 0)
};

// Walks a data set's layout under root (Cityscapes: leftImg8bit[_sequence]/ with gtFine/;
// KITTI: image_2/ with semantic/ and instance/; BDD100K: images/10k/ with
// labels/sem_seg/masks/). An image without labels is bad input naming the image. Cityscapes
// items carry their camera file (camera/<split>/<city>/<stem>_camera.json) where it exists, and
// their odometry (Item::odometry) where the vehicle and timestamp files exist; numbered KITTI frames
// theirs, oxts/<sub>/data/<frame>.txt, where the drive's oxts/<sub>/data/ folder exists (KITTI raw's
// oxts folder, placed under the root as the images are under image_2/).
// Folder links are followed (not into a folder the walk is already inside: a cycle); image names
// match in any case of ".png" (Cityscapes' "_leftImg8bit.PNG" too). The folder `out` (the run's
// output folder, when it lies inside the data set) is left out: its previews are not inputs.
std::vector<Item> discover(Dataset dataset, const std::string& root, const std::string& out = {});
// One item per line: image, labels and optional instances paths, separated by spaces or commas;
// relative paths are relative to the manifest's folder; '#' starts a comment; a UTF-8 byte-order
// mark at the start is skipped. After the paths a line may carry key=value fields:
//  * sequence=NAME: the line's sequence (its group "sequence:NAME"; frames in line order), for
//    `batch --sequence` over frames that are not in a data set's layout (a video's frames with a
//    segmentation model's labels). Without it each line is a sequence of its own.
//  * time_s, speed_m_s, yaw_rate_rad_s (all three or none): the frame's odometry (OdometrySample:
//    seconds from any origin common to the sequence, m/s forward, rad/s turning left), and with
//    them optionally camera_forward_m, camera_left_m, camera_yaw_rad (the camera's place on the
//    vehicle, ISO 8855; 0 by default).
// Bad input (manifest:line: problem) on an unknown key, a key given twice, a value that is not a
// finite number or outside the limits of the data sets' own odometry readers (scene/ego_motion.h:
// |speed| <= 100 m/s, |yaw rate| <= 5 rad/s, the camera within 20 m and 0.5 rad), a sequence
// whose lines mix frames with and without odometry, or whose times do not increase line by line.
std::vector<Item> read_manifest(const std::string& manifest);

// Items of shard `index` of `count`: whole groups, group g (in sorted order) to shard g mod count.
std::vector<Item> shard(const std::vector<Item>& items, int index, int count);
// "I/N" → (I, N); bad input unless 0 <= I < N.
std::pair<int, int> parse_shard(const std::string& text);

// The temporal-noise seed of a group: the run's seed mixed with the group's name, so results do
// not depend on how the work is split or ordered.
uint64_t group_seed(uint64_t base_seed, const std::string& group);

// A resume manifest's parameter record (JSON text) in today's form: manifests written before
// "the preset's value" was recorded as null hold f_number -1 and temperature_c -999 for it
// (values outside the parameters' ranges, so nothing else is read as null); a source path
// recorded with a trailing '/' ("--root cs/") is the same folder without it; the PNG route
// (format "png") recorded the EXR layer set it did not write, and records "sensor,labels" now
// (the preview and the label copies it writes whatever --layers says).
std::string upgrade_params(const std::string& params_json);

uint64_t fnv1a_text(const std::string& text, uint64_t h = kFnv1a64Basis);

// ---- the engine ----------------------------------------------------------------------------
// What a batch run writes and how. Everything but shard, jobs, queue_depth, compute_threads and
// stop decides the results and is recorded in the resume manifest.
struct Options {
  std::string out;            // output folder, created when missing; mirrors the items' keys
  std::string source;         // what the items came from, recorded ("cityscapes /abs/root")
  std::string root;           // the data set's root (refused as `out`), empty for a manifest
  int shard_index = 0, shard_count = 1;
  std::string format = "exr";  // exr, png (8-bit sRGB preview) or both
  LayerSet layers = kBatchLayers;
  std::string compression = kDefaultExrCompression;  // an EXR compression name (io.h)
  bool half = false;          // float layers as half
  SensorSetup sensor;         // settings.seed is the run's seed; each group's is mixed from it
  std::string device_store;   // empty: DeviceStore's default
  scene::ScenePreset scene;
  // Items with a camera file (Cityscapes) use it as their rig in place of scene.rig: their own
  // height, pitch and intrinsics. The command line turns this off when --rig is given.
  bool item_cameras = true;
  // Each group's frames (a sequence: Cityscapes _sequence naming, numbered KITTI files) as one
  // sequence: a scene::SequenceState (scene/luminaires.h: street luminaires in the world, the
  // reflectance normalisation and pitch of its first frame) carried from frame to frame. A group
  // with an unfinished frame is recomputed whole on a re-run, as its state starts at its first
  // frame.
  bool sequences = false;
  // With sequences: each frame's camera pose from the data set's odometry (Item::odometry;
  // scene/ego_motion.h advance_pose from the previous frame's), where the group's first frame has
  // it; a later frame of such a group without it fails (its pose is unknown). Off, or in a group
  // whose first frame has none: every frame at pose 0 (a camera at rest, or crops of one view with
  // their own principal points in per-item camera files).
  bool ego_motion = true;
  int jobs = 1;               // writer threads (not with workers: each writes its own items)
  int queue_depth = 2;        // images in flight (bounds memory); with workers at most this many
  // OpenMP team of the compute stage (with workers: of each); 0: automatic (OpenMP's default;
  // with workers the cores shared among those still busy).
  int compute_threads = 0;
  // Set (e.g. from a signal handler) to stop reading new items; those in flight are finished.
  const std::atomic<bool>* stop = nullptr;
};

struct Progress {
  size_t items = 0;         // in this shard
  size_t already_done = 0;  // finished by an earlier run (checksums verified), skipped
  size_t to_do = 0;
  size_t written = 0;       // finished by this run so far
  size_t failed = 0;
  double elapsed_s = 0;
};
// Called once before the first item (written == 0) and after every finished item, from the
// engine's threads one at a time.
using ProgressFn = std::function<void(const Progress&)>;

// Where the engine's threads spent a run, in ms (bench batch prints them per image): the CPU
// time of each stage's own threads (compute: the calling thread only; its OpenMP workers count in
// the process total) and the wall time each stage was blocked on a queue.
struct StageTimes {
  double reader_cpu_ms = 0, compute_cpu_ms = 0, writer_cpu_ms = 0;
  double reader_wait_ms = 0;       // on a full queue of loaded images
  double compute_wait_in_ms = 0;   // for a loaded image
  double compute_wait_out_ms = 0;  // on a full queue of computed images
  double writer_wait_ms = 0;       // for a computed image (all writers)
};

struct Result {
  Progress progress;                // the final counts
  StageTimes stages;
  std::vector<std::string> errors;  // one per failed item: "<input>: <problem>"
  bool interrupted = false;         // *stop was set before every item was read
};

// The files an item writes under --out (relative paths) with the format ("exr", "png", "both"):
// its EXR and/or PNG preview, then its label and instance copies.
std::vector<std::string> output_paths(const Item& item, const std::string& format);

// Runs shard (shard_index, shard_count) of `items` (all of them: whole groups go to a shard, as
// in shard()). On the CPU backend with EXR files to write, min(queue_depth, cores) workers each
// take an item (with sequences: a group) through reading, the scene and sensor, and writing,
// with an OpenMP team of the cores left to the workers still busy. Otherwise (a GPU backend, or
// PNG only) a reader thread decodes, the calling thread computes, `jobs` writer threads encode;
// bounded queues keep memory flat. Every file is
// written under a temporary name and renamed; temporaries of killed runs of this machine and pid
// namespace are removed first (io.h is_stale_temporary; another machine's are left alone). A
// per-shard manifest (<out>/.photosite-batch/) records each finished item with its files'
// checksums: items whose files are intact are skipped (not an item whose own inputs beyond its
// image recorded there changed since: a Cityscapes camera file, a manifest line's odometry
// fields, with sequences the odometry files its pose was computed from; docs/cli.md "Resume
// manifest keys"). Bad input (Error) before any work: a manifest of other parameters in `out`
// (the message names the first differing parameter), a damaged manifest, an output that exists
// and is not this run's, two different inputs that would be written to one output path (among
// all items, not only the shard's), `out` being the data set root, a bad option. Items that fail (a manifest record that cannot be written among
// the reasons) are listed in Result::errors; the others are written. The bytes written depend
// on neither jobs, queue_depth, compute_threads nor the sharding.
Result run(const std::vector<Item>& items, const Options& options, SensorRunner& backend,
           const ProgressFn& progress = {});

}  // namespace photosite::batch
