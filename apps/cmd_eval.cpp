// `ovo eval`: compares estimated trajectories with ground truth and prints the metrics as JSON
// (ATE after Umeyama alignment, optional RPE, KITTI's segment errors; evo's semantics, see
// eval/metrics.hpp); optional SVGs of one comparison and of every estimate's drift.
#include <cmath>
#include <filesystem>
#include <iostream>
#include <iterator>
#include <string>
#include <vector>
#include <nlohmann/json.hpp>

#include "apps/command.hpp"
#include "apps/run_metrics.hpp"
#include "apps/svg_plot.hpp"
#include "common/error.hpp"
#include "eval/metrics.hpp"
#include "io/text_reader.hpp"
#include "io/trajectory_io.hpp"

namespace ovo::app {
namespace {

struct EvalArgs {
  std::string gt;
  std::vector<std::string> est;     // one or more estimates of the same run
  std::vector<std::string> labels;  // --labels: one per estimate (default: see estimateLabel)
  std::string format = "auto";
  std::string align = "se3";
  double rpe_delta = 0.0;
  std::string rpe_unit = "f";
  double max_diff_s = 0.02;
  bool rpe_pairs_from_reference = false;
  bool rpe_asked = false;  // --rpe-delta was given
  std::string plot;        // --plot OUT.svg
  std::string drift_plot;  // --drift-plot OUT.svg
};

// An ovo run's trajectory is OUT/trajectory.txt: its folder names it; other files by their stem.
std::string estimateLabel(const std::string& file) {
  const std::filesystem::path p(file);
  if (p.filename() == "trajectory.txt" && p.has_parent_path() &&
      !p.parent_path().filename().empty())
    return p.parent_path().filename().string();
  return p.stem().string();
}

// --plot: top view (SE(3)-aligned) and position/yaw error of the matched poses as one SVG.
void writeComparisonPlot(const EvalArgs& args, const std::string& est_file,
                         const eval::Associated& pairs, bool by_index) {
  Trajectory ref = pairs.ref, est = pairs.est;
  for (std::size_t i = 0; i < ref.size(); ++i) {
    if (by_index) ref[i].t_ns = static_cast<Timestamp>(i) * 1'000'000'000;  // 1 "s" per pose
    est[i].t_ns = ref[i].t_ns;  // already matched: pair i with i
  }
  const auto c = app::compareTrajectories(ref, est, 0);
  if (!c) fail("--plot: {} matched poses, at least 3 are needed for a plot", ref.size());
  const std::string title = std::filesystem::path(est_file).filename().string() + " vs " +
                            std::filesystem::path(args.gt).filename().string();
  // Through a temporary file beside it: a full disk leaves no truncated plot.
  try {
    io::writeFileAtomically(
        args.plot, app::svgComparisonDocument(*c, title, by_index ? "pose index" : "time [s]"));
  } catch (const Error& e) {
    fail("--plot: {}", e.what());
  }
}

/// True when a and b name the same file (an input must not be overwritten by the plot).
bool sameFile(const std::string& a, const std::string& b) {
  std::error_code ec;
  return std::filesystem::equivalent(a, b, ec) && !ec;
}

nlohmann::ordered_json statsJson(const eval::Stats& s, bool full) {
  nlohmann::ordered_json j = {
      {"rmse", s.rmse}, {"mean", s.mean}, {"median", s.median}, {"max", s.max}};
  if (full) {
    j["std"] = s.std;
    j["min"] = s.min;
  }
  return j;
}

// One estimate against the ground truth: the JSON object of `ovo eval` and the matched poses.
nlohmann::ordered_json evalOne(const EvalArgs& args, const io::TrajectoryFile& gt,
                               const std::string& est_file, io::TrajectoryFormat format,
                               eval::AlignMode align, eval::DeltaUnit unit,
                               eval::Associated* pairs_out, bool* by_index_out) {
  const io::TrajectoryFormat est_format =
      format == io::TrajectoryFormat::kEurocCsv ? io::TrajectoryFormat::kTum : format;
  const io::TrajectoryFile est = io::readTrajectory(est_file, est_format);

  // KITTI (evo's `kitti` mode) and files without stamps: pose i with pose i.
  const bool by_index = format == io::TrajectoryFormat::kKitti || !gt.has_time || !est.has_time;
  if (by_index && gt.poses.size() != est.poses.size())
    fail(
        "{} has {} poses and {} has {}: KITTI files and files without time stamps are matched "
        "by index and must have the same number of poses",
        args.gt, gt.poses.size(), est_file, est.poses.size());
  const eval::Associated pairs =
      by_index ? eval::associateByIndex(gt.poses, est.poses)
               : eval::associateByTime(gt.poses, est.poses, fromSeconds(args.max_diff_s));
  if (pairs.size() == 0)
    fail("no pose of {} is within {} s of a pose of {}: nothing to compare", est_file,
         args.max_diff_s, args.gt);

  const auto ate = eval::computeAte(pairs, align);
  if (!ate)
    fail("cannot align {} onto {}: {} matched poses, at least 3 not on one line are needed",
         est_file, args.gt, pairs.size());
  nlohmann::ordered_json out;
  if (args.est.size() > 1) out["est"] = est_file;
  out["pairs"] = pairs.size();
  out["align"] = eval::alignModeName(align);
  out["scale"] = ate->alignment.scale;
  out["ate"] = statsJson(ate->trans_m, true);

  if (args.rpe_asked) {
    eval::RpeOptions options;
    options.delta = args.rpe_delta;
    options.unit = unit;
    options.pairs_from_reference = args.rpe_pairs_from_reference;
    const auto rpe = eval::computeRpe(pairs, options);
    if (!rpe)
      fail("RPE: no pose pair is {} {} apart in {} matched poses of {}: use a smaller "
           "--rpe-delta",
           args.rpe_delta, args.rpe_unit, pairs.size(), est_file);
    out["rpe"] = {{"delta", args.rpe_delta},
                  {"unit", args.rpe_unit},
                  {"pairs", rpe->id_pairs.size()},
                  {"trans", statsJson(rpe->trans, false)},
                  {"rot_deg", statsJson(rpe->rot, false)}};
  }
  // KITTI's segment errors at the lengths the field reports (only those the path reaches).
  out["segments"] = segmentsJson<nlohmann::ordered_json>(eval::segmentErrors(pairs));
  *pairs_out = pairs;
  *by_index_out = by_index;
  return out;
}

int runEval(const EvalArgs& args) {
  const io::TrajectoryFormat format = io::parseTrajectoryFormat(args.format);
  const auto align = eval::parseAlignMode(args.align);
  if (!align) fail("--align: expected se3, sim3 or none, got '{}'", args.align);
  const auto unit = eval::parseDeltaUnit(args.rpe_unit);
  if (!unit) fail("--rpe-unit: expected m, s or f, got '{}'", args.rpe_unit);
  if (args.rpe_asked && !(args.rpe_delta > 0.0 && std::isfinite(args.rpe_delta)))
    fail("--rpe-delta: expected a delta > 0, got {}", args.rpe_delta);
  if (args.rpe_asked && *unit == eval::DeltaUnit::kFrames &&
      args.rpe_delta != std::floor(args.rpe_delta))
    fail("--rpe-delta: a delta in frames must be a whole number, got {}", args.rpe_delta);
  if (!(args.max_diff_s >= 0.0 && args.max_diff_s <= 3600.0))
    fail("--max-diff: expected a time in [0, 3600] s, got {}", args.max_diff_s);
  if (!args.plot.empty() && args.est.size() != 1)
    fail("--plot: compares one estimate with the ground truth, got {} --est; use --drift-plot "
         "for several",
         args.est.size());
  if (!args.labels.empty() && args.labels.size() != args.est.size())
    fail("--labels: expected one label per --est ({}), got {}", args.est.size(),
         args.labels.size());
  for (const std::string* out : {&args.plot, &args.drift_plot}) {
    if (out->empty()) continue;
    const char* option = out == &args.plot ? "--plot" : "--drift-plot";
    bool clash = sameFile(*out, args.gt);
    for (const auto& e : args.est) clash = clash || sameFile(*out, e);
    if (clash) fail("{}: '{}' is one of the input trajectories; choose another file", option, *out);
  }

  // euroc: the ground truth is EuRoC csv and the estimates TUM, as evo's `euroc` mode.
  const io::TrajectoryFormat gt_format =
      format == io::TrajectoryFormat::kEurocCsv ? io::TrajectoryFormat::kEurocCsv : format;
  const io::TrajectoryFile gt = io::readTrajectory(args.gt, gt_format);

  std::vector<nlohmann::ordered_json> results;
  std::vector<DriftSeries> drift;
  const char* colours[] = {"#d95f02", "#1b9e77", "#7570b3", "#e7298a", "#66a61e", "#e6ab02"};
  eval::Associated first_pairs;
  bool first_by_index = false;
  for (std::size_t k = 0; k < args.est.size(); ++k) {
    eval::Associated pairs;
    bool by_index = false;
    results.push_back(evalOne(args, gt, args.est[k], format, *align, *unit, &pairs, &by_index));
    if (!args.drift_plot.empty()) {
      const auto curve = eval::driftAlongPath(pairs, eval::kDriftScaleWindowM, chooseTopView(pairs.ref).up);
      if (!curve)
        fail("--drift-plot: {} cannot be aligned on its first pose ({} matched poses)",
             args.est[k], pairs.size());
      drift.push_back({args.labels.empty() ? estimateLabel(args.est[k]) : args.labels[k], *curve,
                       colours[k % std::size(colours)]});
    }
    if (k == 0) {
      first_pairs = std::move(pairs);
      first_by_index = by_index;
    }
  }
  // The plots last: a failed step before them leaves no file behind.
  if (!args.plot.empty()) writeComparisonPlot(args, args.est[0], first_pairs, first_by_index);
  if (!args.drift_plot.empty()) {
    try {
      io::writeFileAtomically(
          args.drift_plot,
          svgDriftDocument(drift, "Drift against the distance driven: " +
                                      std::filesystem::path(args.gt).filename().string()));
    } catch (const Error& e) {
      fail("--drift-plot: {}", e.what());
    }
  }
  if (results.size() == 1) {
    std::cout << results[0].dump(2) << std::endl;
  } else {
    nlohmann::ordered_json out;
    out["estimates"] = results;
    std::cout << out.dump(2) << std::endl;
  }
  return 0;
}

CommandRunner setupEval(CLI::App& sub) {
  auto args = std::make_shared<EvalArgs>();
  sub.add_option("--gt", args->gt, "Ground-truth trajectory file")->required();
  sub.add_option("--est", args->est,
                 "Estimated trajectory file; several --est give a JSON object with one entry per "
                 "estimate (\"estimates\")")
      ->required();
  sub.add_option("--labels", args->labels,
                 "Names of the estimates in --drift-plot (default: an ovo run's output folder, "
                 "else the file's stem)")
      ->delimiter(',');
  sub.add_option("--format", args->format,
                 "tum | kitti | euroc (ground truth EuRoC csv, estimate TUM) | auto")
      ->capture_default_str();
  sub.add_option("--align", args->align, "se3 | sim3 | none")->capture_default_str();
  CLI::Option* rpe_delta =
      sub.add_option("--rpe-delta", args->rpe_delta, "RPE delta (RPE only when given)");
  sub.add_option("--rpe-unit", args->rpe_unit, "RPE delta unit: m (path) | s | f (frames)")
      ->capture_default_str();
  sub.add_flag("--rpe-pairs-from-reference", args->rpe_pairs_from_reference,
               "Pick RPE pairs on the reference path (evo's default picks them on the estimate)");
  sub.add_option("--max-diff", args->max_diff_s, "Max. time difference for association [s]")
      ->capture_default_str();
  sub.add_option("--plot", args->plot,
                 "Write an SVG: top view (SE(3)-aligned) and position/yaw error over time");
  sub.add_option("--drift-plot", args->drift_plot,
                 "Write an SVG: position, heading and scale error of every --est against the "
                 "distance driven (aligned on the first pose)");
  return [args, rpe_delta] {
    args->rpe_asked = rpe_delta->count() > 0;
    return runEval(*args);
  };
}

}  // namespace
}  // namespace ovo::app

OVO_REGISTER_COMMAND(eval, "Compare a trajectory with ground truth (ATE, RPE) as JSON",
                     ovo::app::setupEval);
