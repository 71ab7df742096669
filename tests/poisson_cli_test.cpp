// `--poisson` on the sensor commands: the mode chosen is the mode run and the mode recorded in
// the EXR header (photosite/poisson); an unknown mode is bad input.
#include <gtest/gtest.h>

#include <filesystem>

#include "photosite/io.h"
#include "test_util.h"

using namespace photosite;

TEST(PoissonCli, ExposeAndFlatRecordTheModeTheyRan) {
  test::TempDir dir;
  const std::string store = " --device-store '" + dir.file("store") + "'";
  ASSERT_EQ(test::run_cli("chart --out '" + dir.file("scene.exr") + "' --width 64 --height 48").exit_code, 0);
  const std::string expose = "expose --radiance '" + dir.file("scene.exr") + "' --preset sony-imx174 --seed 3" + store;
  ASSERT_EQ(test::run_cli(expose + " --out '" + dir.file("default.exr") + "'").exit_code, 0);
  ASSERT_EQ(test::run_cli(expose + " --poisson exact --out '" + dir.file("exact.exr") + "'").exit_code, 0);
  ASSERT_EQ(test::run_cli(expose + " --poisson cornish-fisher --out '" + dir.file("cf.exr") + "'").exit_code, 0);
  auto def = read_exr(dir.file("default.exr")), ex = read_exr(dir.file("exact.exr")), cf = read_exr(dir.file("cf.exr"));
  EXPECT_EQ(def.attributes["photosite/poisson"], "exact");  // the default
  EXPECT_EQ(ex.attributes["photosite/poisson"], "exact");
  EXPECT_EQ(cf.attributes["photosite/poisson"], "cornish-fisher");
  EXPECT_EQ(def.channels["electrons.Y"].vec(), ex.channels["electrons.Y"].vec());
  // The chart's bright patches have means above 10, where the two modes draw differently.
  EXPECT_NE(ex.channels["electrons.Y"].vec(), cf.channels["electrons.Y"].vec());
  const std::string flat = "flat --photons 500 --wavelength-nm 525 --preset sony-imx174 --width 32 --height 24 "
                           "--frames 1 --poisson normal" + store;
  ASSERT_EQ(test::run_cli(flat + " --out '" + dir.file("flat.exr") + "'").exit_code, 0);
  EXPECT_EQ(read_exr(dir.file("flat.exr")).attributes["photosite/poisson"], "normal");
}

TEST(PoissonCli, UnknownModeIsBadInput) {
  test::TempDir dir;
  const std::string out = dir.file("o.exr");
  auto r = test::run_cli("flat --photons 5 --wavelength-nm 525 --preset sony-imx174 --width 4 --height 4 --frames 1 "
                         "--poisson exactish --device-store '" + dir.file("store") + "' --out '" + out + "'");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("unknown Poisson method 'exactish'"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(out));
}
