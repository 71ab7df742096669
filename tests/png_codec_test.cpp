// PNG by hand (core/png_codec.h): the decoder gives what the general reader (libspng, core/io.cpp)
// and OpenImageIO give for the data sets' files, and every file the encoder writes reads back through OpenCV's libpng equal to the
// image in memory, for every filter and deflater.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <OpenImageIO/imageio.h>
#include <opencv2/imgcodecs.hpp>
#include <zlib.h>

#include "core/png_codec.h"
#include "photosite/error.h"
#include "photosite/io.h"
#include "test_util.h"

using namespace photosite;
namespace fs = std::filesystem;

namespace {
std::vector<std::string> data_set_pngs() {
  std::vector<std::string> v;
  for (const fs::path dir : {test::shared_dir() / "data" / "cityscapes",
                             fs::path(PHOTOSITE_SOURCE_DIR) / "samples"}) {
    std::error_code ec;
    if (!fs::is_directory(dir, ec)) continue;
    for (const auto& e : fs::recursive_directory_iterator(dir))
      if (e.path().extension() == ".png") v.push_back(e.path().string());
  }
  std::sort(v.begin(), v.end());
  return v;
}

std::vector<uint8_t> bytes_of(const std::string& s) { return {s.begin(), s.end()}; }

// `png` with ancillary chunks (type, data) inserted after IHDR, each with its CRC-32.
std::string with_chunks(const std::string& png, const std::vector<std::pair<std::string, std::string>>& chunks) {
  std::string out = png.substr(0, 8 + 12 + 13);  // signature and IHDR
  for (const auto& [type, data] : chunks) {
    const std::string td = type + data;
    const uint32_t n = static_cast<uint32_t>(data.size());
    const uint32_t crc = static_cast<uint32_t>(crc32(0, reinterpret_cast<const Bytef*>(td.data()), td.size()));
    for (int s = 24; s >= 0; s -= 8) out += static_cast<char>(n >> s & 0xff);
    out += td;
    for (int s = 24; s >= 0; s -= 8) out += static_cast<char>(crc >> s & 0xff);
  }
  return out + png.substr(8 + 12 + 13);
}
std::string be32s(uint32_t v) { return {char(v >> 24), char(v >> 16 & 0xff), char(v >> 8 & 0xff), char(v & 0xff)}; }

// A test image: smooth ramps, a noisy band and flat runs, so every filter type wins somewhere.
std::vector<uint8_t> test_image(int w, int h, int ch, uint32_t seed) {
  std::mt19937 rng(seed);
  std::vector<uint8_t> v(static_cast<size_t>(w) * h * ch);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < ch; ++c) {
        const size_t i = (static_cast<size_t>(y) * w + x) * ch + c;
        v[i] = y < h / 3 ? static_cast<uint8_t>(x * 7 + y * 3 + c * 50)
               : y < 2 * h / 3 ? static_cast<uint8_t>(rng())
                               : static_cast<uint8_t>(x < w / 2 ? 17 : 200);
      }
  return v;
}
}  // namespace

TEST(PngCodec, DecodesTheDataSetsFilesAsTheGeneralReaderAndOpenImageIODo) {
  const auto files = data_set_pngs();
  if (files.empty()) GTEST_SKIP() << "no PNG under ../shared/data/cityscapes or samples/";
  int fast = 0;
  for (const auto& f : files) {
    SCOPED_TRACE(f);
    std::ifstream in(f, std::ios::binary);
    const std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(in)), {});
    const bool taken = png::decode(bytes, max_frame_pixels()).has_value();
    fast += taken;
    ImageFileInfo a, b;
    const ImageU16 u = read_image_u16(f, &a), ug = detail::read_image_u16_general(f, &b);
    ASSERT_EQ(u.width(), ug.width());
    ASSERT_EQ(u.height(), ug.height());
    ASSERT_EQ(u.channels(), ug.channels());
    EXPECT_TRUE(std::equal(u.vec().begin(), u.vec().end(), ug.vec().begin()));
    EXPECT_EQ(a.format, b.format);
    EXPECT_EQ(a.bits_per_sample, b.bits_per_sample);
    EXPECT_EQ(a.channels, b.channels);
    EXPECT_EQ(a.is_float, b.is_float);
    EXPECT_EQ(a.srgb_encoded, b.srgb_encoded);
    const ImageF im = read_image(f, &a), img = detail::read_image_general(f, &b);
    ASSERT_EQ(im.size(), img.size());
    EXPECT_EQ(std::memcmp(im.data(), img.data(), im.size() * sizeof(float)), 0) << "float samples differ";
    EXPECT_EQ(a.srgb_encoded, b.srgb_encoded);
    EXPECT_EQ(a.bits_per_sample, b.bits_per_sample);
    // And OpenImageIO's floats, which photosite read these files through before.
    auto oiio = OIIO::ImageInput::open(f);
    ASSERT_TRUE(oiio);
    std::vector<float> ref(im.size());
    ASSERT_TRUE(oiio->read_image(0, 0, 0, oiio->spec().nchannels, OIIO::TypeDesc::FLOAT, ref.data()));
    EXPECT_EQ(std::memcmp(im.data(), ref.data(), im.size() * sizeof(float)), 0) << "OpenImageIO's float samples differ";
  }
  EXPECT_GT(fast, 0) << "the decoder took none of the data sets' files";
}

TEST(PngCodec, EveryEncoderSettingReadsBackThroughOpenCVUnchanged) {
  const std::pair<png::Deflater, int> deflaters[] = {
      {png::Deflater::Zlib, 0}, {png::Deflater::Zlib, 1}, {png::Deflater::Zlib, 2}, {png::Deflater::Zlib, 3},
      {png::Deflater::Libdeflate, -1}, {png::Deflater::HuffmanOnly, -1}};
  for (const int ch : {1, 3})
    for (const auto [w, h] : {std::pair{37, 23}, std::pair{1, 1}, std::pair{256, 5}}) {
      const auto img = test_image(w, h, ch, static_cast<uint32_t>(w * 10 + ch));
      for (const auto& [deflater, strategy] : deflaters)
        for (int f = 0; f <= 5; ++f) {
          png::EncodeOptions o;
          o.deflater = deflater;
          o.level = deflater == png::Deflater::Zlib ? 1 : 6;
          o.zlib_strategy = std::max(0, strategy);
          o.filter = static_cast<png::Filter>(f);
          SCOPED_TRACE(::testing::Message() << ch << " channels " << w << "x" << h << " filter " << f
                                            << " strategy " << strategy);
          const std::string file = png::encode(img.data(), w, h, ch, o);
          const std::vector<uint8_t> bytes = bytes_of(file);
          const cv::Mat m = cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
          ASSERT_FALSE(m.empty());
          ASSERT_EQ(m.cols, w);
          ASSERT_EQ(m.rows, h);
          ASSERT_EQ(m.channels(), ch);
          ASSERT_EQ(m.depth(), CV_8U);
          for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x)
              for (int c = 0; c < ch; ++c)  // OpenCV gives BGR
                ASSERT_EQ(m.ptr<uint8_t>(y)[x * ch + (ch == 3 ? 2 - c : 0)],
                          img[(static_cast<size_t>(y) * w + x) * ch + c]);
          const auto d = png::decode(bytes, max_frame_pixels());
          ASSERT_TRUE(d);
          EXPECT_EQ(d->u8, img);
        }
    }
}

TEST(PngCodec, WritePng8FilesAreStandardPngs) {
  test::TempDir dir;
  const int w = 61, h = 17;
  const auto px = test_image(w, h, 3, 5);
  ImageU8 img(w, h, 3, uninitialized);
  std::copy(px.begin(), px.end(), img.data());
  write_png8(dir.file("p.png"), img);
  const cv::Mat m = cv::imread(dir.file("p.png"), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(m.type(), CV_8UC3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c) ASSERT_EQ(m.ptr<uint8_t>(y)[3 * x + 2 - c], img.at(x, y, c));
  // And through our reader (the decoder) and the general one.
  const ImageU16 a = read_image_u16(dir.file("p.png")), b = detail::read_image_u16_general(dir.file("p.png"));
  for (size_t i = 0; i < img.size(); ++i) {
    ASSERT_EQ(a[i], img[i]);
    ASSERT_EQ(b[i], img[i]);
  }
}

// What the decoder does not take goes to the general reader (libspng): RGBA, damage (a flipped bit
// in the data: CRC; a cut file), whose errors name the file.
TEST(PngCodec, OtherAndDamagedFilesGoToTheGeneralReader) {
  test::TempDir dir;
  const auto rgba = test_image(9, 7, 4, 3);
  cv::imwrite(dir.file("rgba.png"), cv::Mat(7, 9, CV_8UC4, const_cast<uint8_t*>(rgba.data())));
  std::ifstream in(dir.file("rgba.png"), std::ios::binary);
  EXPECT_FALSE(png::decode(std::vector<uint8_t>((std::istreambuf_iterator<char>(in)), {}), max_frame_pixels()));
  const ImageF a = read_image(dir.file("rgba.png")), b = detail::read_image_general(dir.file("rgba.png"));
  EXPECT_EQ(a.channels(), 4);
  EXPECT_EQ(a.vec(), b.vec());

  const auto px = test_image(40, 30, 3, 9);
  const std::string good = png::encode(px.data(), 40, 30, 3, png::default_encode_options());
  std::string flipped = good;
  flipped[good.size() / 2] ^= 0x10;
  EXPECT_FALSE(png::decode(bytes_of(flipped), max_frame_pixels()));
  EXPECT_FALSE(png::decode(bytes_of(good.substr(0, good.size() - 20)), max_frame_pixels()));
  EXPECT_FALSE(png::decode(bytes_of(good), 40 * 30 - 1)) << "a frame beyond the pixel limit";
  std::ofstream(dir.file("cut.png"), std::ios::binary) << good.substr(0, good.size() / 2);
  const std::string e = test::error_of([&] { read_image(dir.file("cut.png")); });
  EXPECT_NE(e.find("cut.png"), std::string::npos) << e;
}

// Files re-saved by image tools carry sRGB (with the gAMA and cHRM that the PNG specification
// asks writers to put beside it), pHYs and tEXt chunks, as the shared Cityscapes frames do: the
// decoder takes them, with the general reader's samples and colour space; gAMA alone (here 1.0,
// linear) changes the colour space, so it goes to the general reader, which reads it as linear.
TEST(PngCodec, AncillaryChunksBesideSrgbAreTakenGammaAloneIsNot) {
  test::TempDir dir;
  const auto px = test_image(40, 30, 3, 5);
  const std::string plain = png::encode(px.data(), 40, 30, 3, png::default_encode_options());
  const std::string chrm = be32s(31270) + be32s(32900) + be32s(64000) + be32s(33000) + be32s(30000) +
                           be32s(60000) + be32s(15000) + be32s(6000);  // the sRGB chromaticities x 1e5
  const std::string tagged = with_chunks(plain, {{"gAMA", be32s(45455)}, {"sRGB", std::string(1, '\0')},
                                                 {"cHRM", chrm}, {"pHYs", be32s(2835) + be32s(2835) + "\x01"},
                                                 {"tEXt", std::string("Software\0by hand", 16)}});
  ASSERT_TRUE(png::decode(bytes_of(tagged), max_frame_pixels())) << "sRGB with gAMA/cHRM, pHYs, tEXt: taken";
  std::ofstream(dir.file("tagged.png"), std::ios::binary) << tagged;
  ImageFileInfo a, b;
  const ImageF fast = read_image(dir.file("tagged.png"), &a), general = detail::read_image_general(dir.file("tagged.png"), &b);
  EXPECT_EQ(fast.vec(), general.vec());
  EXPECT_TRUE(a.srgb_encoded);
  EXPECT_EQ(a.srgb_encoded, b.srgb_encoded);

  const std::string linear = with_chunks(plain, {{"gAMA", be32s(100000)}});
  EXPECT_FALSE(png::decode(bytes_of(linear), max_frame_pixels())) << "gAMA without sRGB: left to the general reader";
  std::ofstream(dir.file("linear.png"), std::ios::binary) << linear;
  ImageFileInfo c;
  const ImageF lin = read_image(dir.file("linear.png"), &c);
  EXPECT_FALSE(c.srgb_encoded) << "OpenImageIO reads gamma 1.0 as linear";
  EXPECT_EQ(lin.vec(), general.vec()) << "the same samples";
  EXPECT_FALSE(png::decode(bytes_of(with_chunks(plain, {{"cHRM", chrm}})), max_frame_pixels()));
  EXPECT_FALSE(png::decode(bytes_of(with_chunks(plain, {{"iCCP", std::string("x\0\0", 3)}})), max_frame_pixels()));
}
