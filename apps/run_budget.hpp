// Compute budgets for `ovo run --budget`: named presets that trade accuracy for time on
// a robot's small computer, as configuration keys. A preset only fills keys that the --config file
// and --set leave unset, so each of its choices can still be overridden one by one. What each
// preset costs and saves on the simulated runs and KITTI 07 is in the README ("Speed").
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "common/config.hpp"

namespace ovo::app {

/// The presets' names: "full" (the defaults: every key as configured) and "low".
const std::vector<std::string>& budgetNames();

/// The keys a preset sets and their values (none for "full"); throws ovo::Error naming the
/// preset and the known ones for another name.
const std::vector<std::pair<std::string, std::string>>& budgetKeys(const std::string& name);

/// Sets the preset's keys that `config` does not hold yet and that `estimator` ("window", "kf",
/// "vo") reads: the frontend's ("frontend.", "ransac.") for every estimator, an estimator's own
/// ("window.", ...) only for it.
void applyBudget(Config& config, const std::string& name, const std::string& estimator);

}  // namespace ovo::app
