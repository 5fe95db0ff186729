// ovo run --budget: the presets fill only the keys the user left unset, and an unknown name is
// an error that names it and the known ones.
#include "apps/run_budget.hpp"

#include <gtest/gtest.h>

#include "common/error.hpp"

namespace ovo::app {
namespace {

TEST(RunBudget, LowFillsItsKeysAndLeavesTheUsersOwn) {
  Config config;
  config.applyOverride("window.max_iterations=7");
  applyBudget(config, "low", "window");
  EXPECT_EQ(config.get<int>("window.max_iterations", 0), 7);  // the user's
  EXPECT_TRUE(config.get<bool>("frontend.half_resolution", false));
  ASSERT_FALSE(budgetKeys("low").empty());
  for (const auto& [key, value] : budgetKeys("low")) EXPECT_TRUE(config.has(key)) << key;
}

TEST(RunBudget, OtherEstimatorsGetOnlyTheFrontendsKeys) {
  // kf and vo read no window.* key: one would be an unknown key (Config::checkAllUsed).
  for (const std::string estimator : {"kf", "vo"}) {
    Config config;
    applyBudget(config, "low", estimator);
    EXPECT_TRUE(config.get<bool>("frontend.half_resolution", false)) << estimator;
    EXPECT_FALSE(config.has("window.max_iterations")) << estimator;
  }
}

TEST(RunBudget, FullChangesNothingAndAnUnknownNameIsAnError) {
  Config config;
  applyBudget(config, "full", "window");
  EXPECT_FALSE(config.has("frontend.half_resolution"));
  EXPECT_FALSE(config.has("window.max_iterations"));
  try {
    applyBudget(config, "tiny", "window");
    FAIL() << "no error";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("tiny"), std::string::npos) << what;
    EXPECT_NE(what.find("low"), std::string::npos) << what;
  }
}

}  // namespace
}  // namespace ovo::app
