#pragma once
// Runs the real `stickslip` binary in a test directory and captures its exit code and output.
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "support/temp_dir.h"

namespace stickslip::testing {

inline std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

/// A temp directory to run `stickslip` in: write() files into it, run() the binary there.
class CliSandbox {
 public:
  struct Result {
    int code;  ///< exit code, -1 if killed by a signal
    std::string out, err;
  };
  explicit CliSandbox(const std::string& prefix) : tmp_(prefix) {}

  const std::filesystem::path& dir() const { return tmp_.path(); }
  std::filesystem::path write(const std::string& name, const std::string& text) const {
    std::ofstream(dir() / name, std::ios::binary) << text;
    return dir() / name;
  }
  /// Runs `stickslip ARGS` (a shell word list) in dir().
  Result run(const std::string& args) const {
    const std::string bin = std::string(STICKSLIP_BINARY_DIR) + "/client/stickslip";
    const std::string cmd = "cd '" + dir().string() + "' && '" + bin + "' " + args + " >'" +
                            (dir() / "out.txt").string() + "' 2>'" +
                            (dir() / "err.txt").string() + "'";
    const int status = std::system(cmd.c_str());
    return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, slurp(dir() / "out.txt"),
            slurp(dir() / "err.txt")};
  }

 private:
  TempDir tmp_;
};

}  // namespace stickslip::testing
