// The few lines `ovo run` ends with (instead of metrics.json's dump, which --json prints): what
// ran on what, the accuracy against ground truth when there is one (ATE, final yaw, scale), the
// speed (realtime factor) and where the report and the other outputs are.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

namespace ovo::app {

/// `out` may be empty (no --out: nothing written).
std::string runSummary(const nlohmann::json& metrics, const std::string& estimator,
                       const std::string& dataset, const std::filesystem::path& out);

}  // namespace ovo::app
