// An output folder written through a hidden staging folder beside it and moved into place by
// commit(): a failed or interrupted command never leaves a half-written folder, and what was at
// the target stays until commit() replaces it. Used by `ovo simulate` (DatasetWriter) and
// `ovo run`. The target is checked before any work is done: it must be a folder (or nothing),
// must not hold the current folder, and is only replaced when the policy allows.
#pragma once

#include <filesystem>
#include <set>
#include <string>

namespace ovo::io {

class StagedFolder {
 public:
  enum class Replace {
    kIfEmpty,      // an existing target must be an empty folder
    kAlways,       // an existing folder is replaced (e.g. `ovo simulate --overwrite`)
    kIfOwnOutput,  // an existing folder is replaced when it holds only names in own_names (the
                   // output of an earlier run of the same command), else it is an error
  };

  /// `option` names the command-line option in messages (e.g. "--out"). Throws ovo::Error when
  /// the target cannot be used or the staging folder cannot be created.
  StagedFolder(std::filesystem::path target, std::string option, Replace replace,
               std::set<std::string> own_names = {});
  /// Removes the staging folder unless commit() succeeded.
  ~StagedFolder();
  StagedFolder(const StagedFolder&) = delete;
  StagedFolder& operator=(const StagedFolder&) = delete;

  const std::filesystem::path& target() const { return target_; }    // absolute, normalised
  const std::filesystem::path& staging() const { return staging_; }  // write here

  /// Replaces the target with the staging folder (checking the policy again: the target may have
  /// appeared meanwhile). Throws ovo::Error naming both folders on failure.
  void commit();

 private:
  /// Throws unless the target, as it is now, may be replaced.
  void checkReplaceable() const;

  std::filesystem::path target_;
  std::filesystem::path staging_;
  std::string option_;
  Replace replace_;
  std::set<std::string> own_names_;
  bool committed_ = false;
};

}  // namespace ovo::io
