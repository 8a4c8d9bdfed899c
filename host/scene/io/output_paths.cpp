// host/scene/io/output_paths.cpp — the checks every command makes of a path
// it will write before it does any work (include/manyrods/runner.h): not one
// of its inputs, and an extension that says the file's format.
#include <algorithm>
#include <cctype>
#include <filesystem>
#include <string>
#include <vector>

#include "manyrods/runner.h"

namespace manyrods::scene {

namespace fs = std::filesystem;

namespace {

std::string lower_extension(const std::string& path) {
  std::string e = fs::path(path).extension().string();
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return e;
}

std::string joined(const std::vector<std::string>& v) {
  std::string s;
  for (std::size_t i = 0; i < v.size(); ++i) s += (i ? (i + 1 == v.size() ? " or " : ", ") : "") + v[i];
  return s;
}

}  // namespace

void check_not_input(const std::string& output, const std::vector<std::string>& inputs, const std::string& what) {
  std::error_code ec;
  if (!fs::exists(output, ec)) return;  // (a file that is not there is nobody's input)
  for (const std::string& in : inputs) {
    std::error_code e2;
    if (!in.empty() && fs::exists(in, e2) && fs::equivalent(output, in, e2))
      throw SceneError(what + " " + output + ": is " + (output == in ? "" : "the same file as ") + "the input " + in +
                       ", which writing it would destroy; write to another path (nothing was written)");
  }
}

void check_extension(const std::string& output, const std::vector<std::string>& extensions, const std::string& what,
                     const std::string& format) {
  const std::string e = lower_extension(output);
  if (std::find(extensions.begin(), extensions.end(), e) != extensions.end()) return;
  throw SceneError(what + " " + output + ": " + format + " is written to a " + joined(extensions) + " file, not " +
                   (e.empty() ? "a file without an extension" : "a " + e + " file") + " (nothing was written)");
}

void check_h5_output(const std::string& output, const std::vector<std::string>& inputs, const std::string& what) {
  const std::string e = lower_extension(output);
  for (const char* other : {".toml", ".usda", ".usd", ".usdc", ".usdz", ".obj", ".csv", ".json", ".png", ".gif"})
    if (e == other)
      throw SceneError(what + " " + output + ": the output is an HDF5 file; a " + e +
                       " name says another format (use .h5; nothing was written)");
  check_not_input(output, inputs, what);
}

}  // namespace manyrods::scene
