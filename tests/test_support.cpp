#include "tests/test_support.hpp"

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>

namespace ovo::test {

std::filesystem::path sharedData(const std::string& rel) {
  const char* env = std::getenv("OVO_SHARED_DATA");
  std::filesystem::path root = env ? env : OVO_SHARED_DATA_DIR;
  return rel.empty() ? root : root / rel;
}

std::filesystem::path sourcePath(const std::string& rel) {
  return std::filesystem::path(OVO_SOURCE_DIR) / rel;
}

std::filesystem::path tempDir() {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::string name = info ? std::string(info->test_suite_name()) + "." + info->name() : "ovo_test";
  for (char& c : name)
    if (c == '/') c = '_';
  auto dir =
      std::filesystem::temp_directory_path() / ("ovo_test_" + std::to_string(::getpid())) / name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

static std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

int runOvo(const std::string& args, std::string* out, std::string* err) {
  const char* bin = std::getenv("OVO_BIN");
  std::string exe = bin ? bin : std::string(OVO_BINARY_DIR) + "/ovo";
  const auto dir = tempDir() / "_run";
  std::filesystem::create_directories(dir);
  const auto out_path = dir / "stdout.txt";
  const auto err_path = dir / "stderr.txt";
  const std::string cmd =
      exe + " " + args + " >" + out_path.string() + " 2>" + err_path.string() + " </dev/null";
  const int status = std::system(cmd.c_str());
  if (out) *out = slurp(out_path);
  if (err) *err = slurp(err_path);
  if (status == -1) return -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

Eigen::MatrixXd numericJacobian(const std::function<Eigen::VectorXd(const Eigen::VectorXd&)>& f,
                                const Eigen::VectorXd& x, double h) {
  const Eigen::VectorXd f0 = f(x);
  Eigen::MatrixXd J(f0.size(), x.size());
  for (int i = 0; i < x.size(); ++i) {
    Eigen::VectorXd xp = x, xm = x;
    xp[i] += h;
    xm[i] -= h;
    J.col(i) = (f(xp) - f(xm)) / (2.0 * h);
  }
  return J;
}

}  // namespace ovo::test
