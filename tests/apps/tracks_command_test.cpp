// `ovo tracks` end to end: the frontend's tracks on a short rendered row against the simulator's
// truth, as a table and as JSON, and a frontend option given with --set changing the answer.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "tests/test_support.hpp"

namespace ovo::test {
namespace {

namespace fs = std::filesystem;

nlohmann::json runTracks(const std::string& extra, const fs::path& json) {
  std::string out, err;
  const int code =
      runOvo("tracks --config '" + sourcePath("configs/sim/vineyard_row.yaml").string() +
                 "' --frames 50 --json '" + json.string() + "' " + extra,
             &out, &err);
  EXPECT_EQ(code, 0) << err;
  EXPECT_NE(out.find("depth edge"), std::string::npos) << out;
  std::ifstream in(json);
  return nlohmann::json::parse(in);
}

const nlohmann::json& kind(const nlohmann::json& j, const std::string& name) {
  for (const auto& k : j["kinds"])
    if (k["kind"] == name) return k;
  ADD_FAILURE() << "no kind " << name;
  static const nlohmann::json none;
  return none;
}

TEST(TracksCommand, GroundTracksAreTrueToAFewTenthsOfAPixelAndTheRefineStepShows) {
  const fs::path dir = tempDir();
  const nlohmann::json j = runTracks("", dir / "default.json");
  const nlohmann::json plain = runTracks("--set frontend.track_refine=false", dir / "plain.json");
  ASSERT_EQ(j["frames"].get<int>(), 50);
  const auto& ground = kind(j, "ground");
  ASSERT_EQ(ground["ages"].size(), 4u);
  const auto& one = ground["ages"][0];
  const auto& five = ground["ages"][1];
  EXPECT_EQ(one["age"].get<int>(), 1);
  EXPECT_GT(one["tracks"].get<int>(), 5000);
  EXPECT_GT(kind(j, "depth edge")["tracks_started"].get<int>(), 1000);
  // Measured on the whole row: 0.137 px after one frame, 0.245 after five.
  EXPECT_LT(one["median_px"].get<double>(), 0.2);
  EXPECT_LT(five["median_px"].get<double>(), 0.35);
  // Without the Lucas-Kanade step the ground tracks wander further (TrackDrift tests).
  EXPECT_GT(kind(plain, "ground")["ages"][1]["median_px"].get<double>(),
            1.2 * five["median_px"].get<double>());
}

TEST(TracksCommand, AnUnknownScenarioFileOrFrontendKeyIsAnError) {
  std::string out, err;
  EXPECT_NE(runOvo("tracks --config /nonexistent/scenario.yaml", &out, &err), 0);
  EXPECT_NE(err.find("/nonexistent/scenario.yaml"), std::string::npos) << err;
  EXPECT_NE(runOvo("tracks --config '" + sourcePath("configs/sim/vineyard_row.yaml").string() +
                       "' --frames 2 --set frontend.track_refine_typo=1",
                   &out, &err),
            0);
  EXPECT_NE(err.find("frontend.track_refine_typo"), std::string::npos) << err;
}

}  // namespace
}  // namespace ovo::test
