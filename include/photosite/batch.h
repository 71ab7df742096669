// Whole data sets: finding the (image, labels, instances) items of a data set's own layout or a
// manifest, grouping sequence frames, sharding deterministically, and the resume manifest.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

namespace photosite::batch {

enum class Dataset { Cityscapes, Kitti, Bdd100k };
Dataset parse_dataset(const std::string& name);  // bad input on anything else
const char* to_string(Dataset d);

struct Item {
  std::string key;          // unique relative path of the output, without extension ('/'-separated)
  std::string image, labels, instances;           // input paths
  std::string labels_rel, instances_rel;          // where the label copies go under --out
  std::string label_format = "auto";
  std::string group;        // sequence id: frames of one group share device, seed and frame count
  int frame = 0;            // frame number within the group (consecutive from 0)
};

// Walks a data set's layout under root (Cityscapes: leftImg8bit[_sequence]/ with gtFine/;
// KITTI: image_2/ with semantic/ and instance/; BDD100K: images/10k/ with
// labels/sem_seg/masks/). An image without labels is bad input naming the image.
std::vector<Item> discover(Dataset dataset, const std::string& root);
// One item per line: image, labels and optional instances paths, separated by spaces or commas;
// relative paths are relative to the manifest's folder; '#' starts a comment.
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
// (values outside the parameters' ranges, so nothing else is read as null).
std::string upgrade_params(const std::string& params_json);

uint64_t fnv1a_file(const std::string& path);  // checksum of a file's bytes
uint64_t fnv1a_text(const std::string& text, uint64_t h = 0xcbf29ce484222325ull);

}  // namespace photosite::batch
