// Cityscapes label decoding and scene presets.
#include <gtest/gtest.h>

#include <fstream>

#include "photosite/error.h"
#include "photosite/io.h"
#include "photosite/scene/labels.h"
#include "photosite/scene/scene_preset.h"
#include "test_util.h"

using namespace photosite;
using namespace photosite::scene;
using test::error_of;

namespace {
ImageU16 ids(std::initializer_list<uint16_t> v, int w) {
  ImageU16 img(w, static_cast<int>(v.size()) / w, 1);
  size_t i = 0;
  for (auto x : v) img[i++] = x;
  return img;
}
void write_codes(const std::string& path, const ImageU16& codes, int bits) {
  ImageF f(codes.width(), codes.height(), codes.channels());
  const float m = bits == 8 ? 255.f : 65535.f;
  for (size_t i = 0; i < f.size(); ++i) f[i] = codes[i] / m;
  write_png(path, f, bits);
}
}  // namespace

TEST(SceneLabels, LabelIdsTrainIdsAndPaletteAgree) {
  const ImageU16 label_ids = ids({7, 11, 23, 26, 0, 33}, 3);
  const ImageU16 train_ids = ids({0, 2, 10, 13, 255, 18}, 3);
  ImageU16 pal(3, 2, 3);
  for (size_t i = 0; i < 6; ++i)
    for (int k = 0; k < 3; ++k) pal[3 * i + k] = label_color(label_ids[i])[k];
  const LabelMap a = decode_labels(label_ids, LabelFormat::Auto, "a.png");
  const LabelMap b = decode_labels(train_ids, LabelFormat::Auto, "b.png");
  const LabelMap c = decode_labels(pal, LabelFormat::Auto, "c.png");
  EXPECT_EQ(a.format, LabelFormat::LabelIds);
  EXPECT_EQ(b.format, LabelFormat::TrainIds);
  EXPECT_EQ(c.format, LabelFormat::Palette);
  for (size_t i = 0; i < 6; ++i) {
    EXPECT_EQ(a.ids[i], label_ids[i]);
    EXPECT_EQ(b.ids[i], label_ids[i]) << i;
    EXPECT_EQ(c.ids[i], label_ids[i]) << i;
  }
}

TEST(SceneLabels, UnknownValuesAndColoursNameTheFileAndPixel) {
  std::string m = error_of([] { decode_labels(ids({7, 40}, 2), LabelFormat::Auto, "bad.png"); });
  EXPECT_NE(m.find("bad.png"), std::string::npos) << m;
  EXPECT_NE(m.find("40"), std::string::npos) << m;
  EXPECT_NE(m.find("(1, 0)"), std::string::npos) << m;
  m = error_of([] { decode_labels(ids({0, 19}, 2), LabelFormat::TrainIds, "t.png"); });
  EXPECT_NE(m.find("t.png"), std::string::npos) << m;
  ImageU16 pal(1, 1, 3);
  pal[0] = 1; pal[1] = 2; pal[2] = 3;
  m = error_of([&] { decode_labels(pal, LabelFormat::Auto, "p.png"); });
  EXPECT_NE(m.find("not in the Cityscapes palette"), std::string::npos) << m;
}

TEST(SceneLabels, FilesSizeCheckResizeAndInstances) {
  test::TempDir d;
  ImageU16 lab(8, 4, 1, 7);
  lab.at(0, 0) = 26;
  write_codes(d.file("l.png"), lab, 8);
  ImageU16 inst(8, 4, 1, 7);
  inst.at(0, 0) = 26003;
  inst.at(1, 0) = 26;  // a class id without instance
  write_codes(d.file("i.png"), inst, 16);
  LabelMap m = read_labels(d.file("l.png"), d.file("i.png"), 8, 4, LabelFormat::Auto, ResizeLabels::None);
  EXPECT_EQ(m.ids.at(0, 0), 26);
  EXPECT_EQ(m.instances.at(0, 0), 26003);
  EXPECT_EQ(m.instances.at(1, 0), 0);
  // Another size: a ParameterError naming the file and resize_labels, which each face re-words
  // with its own spelling (the command line's --resize-labels).
  try {
    read_labels(d.file("l.png"), "", 16, 8, LabelFormat::Auto, ResizeLabels::None);
    FAIL() << "labels of another size accepted";
  } catch (const ParameterError& e) {
    EXPECT_EQ(e.parameter(), "resize_labels");
    EXPECT_NE(std::string(e.what()).find("l.png: labels are 8x4 but the image is 16x8 (pass resize_labels=nearest"),
              std::string::npos) << e.what();
    EXPECT_NE(e.message_for("--resize-labels").find("(pass --resize-labels=nearest"), std::string::npos);
  }
  LabelMap r = read_labels(d.file("l.png"), "", 16, 8, LabelFormat::Auto, ResizeLabels::Nearest);
  EXPECT_EQ(r.ids.width(), 16);
  EXPECT_EQ(r.ids.at(0, 0), 26);
  EXPECT_EQ(r.ids.at(1, 1), 26);
  EXPECT_EQ(r.ids.at(2, 2), 7);
}

TEST(ScenePreset, BundledPresetsLoadAndBadKeysAreNamed) {
  const ScenePreset u = load_scene_preset("night-urban");
  const ScenePreset r = load_scene_preset("night-rural");
  EXPECT_DOUBLE_EQ(u.rho_road, 0.1);
  EXPECT_DOUBLE_EQ(u.rho_sign, 0.7);
  EXPECT_GT(u.street_road_luminance_cd_m2, r.street_road_luminance_cd_m2);
  std::ifstream in(u.file);
  std::string text((std::istreambuf_iterator<char>(in)), {});
  std::string bad = text;
  bad.replace(bad.find("moon_lux = 0.1"), 14, "moon_lux = -1.0");
  std::string m = error_of([&] { parse_scene_preset(bad, "x.toml"); });
  EXPECT_NE(m.find("x.toml"), std::string::npos) << m;
  EXPECT_NE(m.find("ambient.moon_lux"), std::string::npos) << m;
  m = error_of([&] { parse_scene_preset(text + "\n[extra]\nfoo = 1\n", "y.toml"); });
  // The one preset reader's wording (core/toml_schema_detail.h): an unknown table is named.
  EXPECT_NE(m.find("y.toml:"), std::string::npos) << m;
  EXPECT_NE(m.find(": extra: unknown key"), std::string::npos) << m;
  bad = text;
  bad.replace(bad.find("sign_RA = 180"), 13, "");
  m = error_of([&] { parse_scene_preset(bad, "z.toml"); });
  EXPECT_NE(m.find(": retroreflection.sign_RA: required key is missing"), std::string::npos) << m;
  EXPECT_THROW(load_scene_preset("no-such-scene"), Error);
}

// Another frame's instance ids (a mixed-up manifest line): their vehicles' classes disagree with
// these labels on most instance pixels. Refused, naming the file and the first such pixel; a
// minority of disagreeing pixels (another tool's boundaries) is let through.
TEST(SceneLabels, InstancesOfAnotherFrameAreRefused) {
  test::TempDir d;
  ImageU16 lab(8, 4, 1, 7);  // road, a car at columns 0-1
  for (int y = 0; y < 4; ++y) lab.at(0, y) = lab.at(1, y) = 26;
  write_codes(d.file("l.png"), lab, 8);
  ImageU16 other(8, 4, 1, 7);  // the other frame's car at columns 5-7
  for (int y = 0; y < 4; ++y)
    for (int x = 5; x < 8; ++x) other.at(x, y) = 26004;
  write_codes(d.file("other.png"), other, 16);
  const std::string m = error_of([&] {
    read_labels(d.file("l.png"), d.file("other.png"), 8, 4, LabelFormat::Auto, ResizeLabels::None);
  });
  EXPECT_NE(m.find("other.png"), std::string::npos) << m;
  EXPECT_NE(m.find("disagree with the labels on 100.0% of their pixels (first at (5, 0)"), std::string::npos) << m;
  // Its own ids with one boundary pixel off (1 of 8 instance pixels): accepted.
  ImageU16 own(8, 4, 1, 7);
  for (int y = 0; y < 4; ++y) own.at(0, y) = own.at(1, y) = 26001;
  own.at(2, 0) = 26001;  // on road: disagrees
  own.at(1, 3) = 7;
  write_codes(d.file("own.png"), own, 16);
  const LabelMap ok = read_labels(d.file("l.png"), d.file("own.png"), 8, 4, LabelFormat::Auto, ResizeLabels::None);
  EXPECT_EQ(ok.instances.at(0, 0), 26001);
}

TEST(SceneLabels, KittiInstanceCodesAreRecognised) {
  test::TempDir d;
  ImageU16 lab(4, 2, 1, 7);
  lab.at(0, 0) = 26;
  lab.at(1, 0) = 26;
  write_codes(d.file("l.png"), lab, 8);
  ImageU16 inst(4, 2, 1, 7 * 256);  // KITTI: class*256 + n, road without instance number
  inst.at(0, 0) = 26 * 256 + 1;
  inst.at(1, 0) = 26 * 256 + 2;
  write_codes(d.file("i.png"), inst, 16);
  LabelMap m = read_labels(d.file("l.png"), d.file("i.png"), 4, 2, LabelFormat::Auto, ResizeLabels::None);
  EXPECT_EQ(m.instances.at(0, 0), 26001);
  EXPECT_EQ(m.instances.at(1, 0), 26002);
  EXPECT_EQ(m.instances.at(2, 0), 7000);
}
