#include "io/staged_folder.hpp"

#include <fmt/format.h>
#include <unistd.h>

#include <system_error>

#include "common/error.hpp"

namespace ovo::io {
namespace fs = std::filesystem;

namespace {

/// True when `inner` is `outer` or lies inside it (both absolute and normalised).
bool isSameOrInside(const fs::path& inner, const fs::path& outer) {
  auto i = inner.begin();
  for (const fs::path& part : outer) {
    if (part.empty()) break;  // a trailing separator ends the path
    if (i == inner.end() || *i != part) return false;
    ++i;
  }
  return true;
}

fs::path resolved(const fs::path& p) {
  std::error_code ec;
  fs::path r = fs::weakly_canonical(p, ec);
  return ec ? p : r.lexically_normal();
}

}  // namespace

StagedFolder::StagedFolder(fs::path target, std::string option, Replace replace,
                           std::set<std::string> own_names)
    : option_(std::move(option)), replace_(replace), own_names_(std::move(own_names)) {
  if (target.empty()) fail("{}: empty path (expected a folder to write)", option_);
  target_ = fs::absolute(target).lexically_normal();
  if (target_.filename().empty()) target_ = target_.parent_path();  // "out/" is "out"
  if (target_ == target_.root_path() || target_.filename() == "..")
    fail("{} '{}': expected a folder to create or replace, not the file system's root or '..'",
         option_, target.string());
  std::error_code ec;
  const fs::path cwd = fs::current_path(ec);
  if (!ec && isSameOrInside(resolved(cwd), resolved(target_)))
    fail("{} '{}': that folder holds the current folder; choose a new folder for the output",
         option_, target.string());
  checkReplaceable();
  staging_ = target_.parent_path() /
             fmt::format(".{}.partial-{}", target_.filename().string(), ::getpid());
  fs::remove_all(staging_, ec);
  fs::create_directories(staging_, ec);
  if (ec)
    fail("{} '{}': cannot create a folder beside it ('{}'): {}", option_, target.string(),
         staging_.string(), ec.message());
}

StagedFolder::~StagedFolder() {
  if (!committed_) {
    std::error_code ec;
    fs::remove_all(staging_, ec);
  }
}

void StagedFolder::checkReplaceable() const {
  std::error_code ec;
  const fs::file_status st = fs::status(target_, ec);
  if (!fs::exists(st)) return;
  if (!fs::is_directory(st))
    fail("{} '{}': exists and is not a folder (expected a folder to create or replace)", option_,
         target_.string());
  if (fs::is_empty(target_, ec) || replace_ == Replace::kAlways) return;
  if (replace_ == Replace::kIfEmpty)
    fail("{} '{}': already exists and is not an empty folder (remove it or choose another)",
         option_, target_.string());
  for (const fs::directory_entry& e : fs::directory_iterator(target_, ec)) {
    const std::string name = e.path().filename().string();
    if (!own_names_.count(name))
      fail(
          "{} '{}': the folder holds '{}', which is not output of this command; ovo replaces "
          "only its own earlier output (choose a new or empty folder)",
          option_, target_.string(), name);
  }
  if (ec) fail("{} '{}': cannot list the folder: {}", option_, target_.string(), ec.message());
}

void StagedFolder::commit() {
  checkReplaceable();
  std::error_code ec;
  if (fs::exists(target_)) {
    fs::remove_all(target_, ec);
    if (ec) fail("{}: cannot replace '{}': {}", option_, target_.string(), ec.message());
  }
  fs::create_directories(target_.parent_path(), ec);
  fs::rename(staging_, target_, ec);
  if (ec)
    fail("{}: cannot move '{}' to '{}': {}", option_, staging_.string(), target_.string(),
         ec.message());
  committed_ = true;
}

}  // namespace ovo::io
