// docs/validation.md "7h Fuzzing" — the fuzz targets (tests/fuzz/fuzz_targets.h)
// on the committed corpus (tests/fuzz/corpus: the example scenes, small
// outputs, and every input a fuzzer found a crash or hang with), then a short
// deterministic mutation run from it: bytes replaced, inserted, deleted,
// truncated, and (scenes) TOML fragments spliced in. Each input must give a
// scene or file, or the documented error; a crash, a hang or another
// exception fails the test. The coverage-guided runs are tools/run-fuzz
// (libFuzzer, clang, ASan + UBSan).
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "fuzz/fuzz_targets.h"

namespace fs = std::filesystem;

namespace {

std::vector<std::string> corpus(const char* kind) {
  std::vector<std::string> files;
  for (const fs::directory_entry& e : fs::directory_iterator(fs::path(MANYRODS_FUZZ_CORPUS) / kind))
    files.push_back(e.path().string());
  std::sort(files.begin(), files.end());
  return files;
}

std::string slurp(const std::string& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream os;
  os << in.rdbuf();
  return os.str();
}

// One mutation of `s`: 1–8 edits.
std::string mutate(std::string s, std::mt19937& rng, const std::vector<std::string>& fragments) {
  const int edits = 1 + int(rng() % 8);
  for (int i = 0; i < edits; ++i) {
    const std::size_t at = s.empty() ? 0 : rng() % s.size();
    switch (rng() % 5) {
      case 0:
        if (!s.empty()) s[at] = char(rng() % 256);
        break;
      case 1: s.insert(at, 1, char(rng() % 256)); break;
      case 2:
        if (!s.empty()) s.erase(at, 1 + rng() % std::min<std::size_t>(16, s.size() - at));
        break;
      case 3: s.resize(at); break;
      default:
        if (!fragments.empty()) s.insert(at, fragments[rng() % fragments.size()]);
    }
  }
  return s;
}

template <class Target>
void run(const char* kind, int mutations, const std::vector<std::string>& fragments, Target target) {
  const std::vector<std::string> files = corpus(kind);
  ASSERT_FALSE(files.empty());
  std::vector<std::string> seeds;
  for (const std::string& f : files) {
    SCOPED_TRACE(f);
    seeds.push_back(slurp(f));
    target(seeds.back());
  }
  std::mt19937 rng(12345);
  for (int i = 0; i < mutations; ++i) {
    const std::string input = mutate(seeds[rng() % seeds.size()], rng, fragments);
    SCOPED_TRACE(::testing::Message() << kind << " mutation " << i);
    target(input);
  }
}

}  // namespace

TEST(FuzzCorpus, SceneParserGivesASceneOrASceneError) {
  const std::vector<std::string> fragments = {
      "\n[[rods]]\n", "\n[simulation]\n", " = ", "\"auto\"", "1e308", "-1", "nan", "inf", "[", "]", "{", "}",
      ",", "\"", "count = 2147483647\n", "elements = 1000000000\n", "resolution = 512\n", "[[colliders]]\n",
      "kind = \"mesh\"\n", "file = \"/dev/zero\"\n", "file = \"/\"\n", "\n[contact]\nself = true\n",
      "root = { motion = \"keyframes\", times = [0.0, 0.0] }\n", "placement = { kind = \"sphere\" }\n",
      "\xff\xfe", "\\u0000", "0x7fffffffffffffff"};
  run("scene", 20000, fragments, [](const std::string& s) {
    manyrods::fuzz::scene_text(reinterpret_cast<const std::uint8_t*>(s.data()), s.size());
  });
}

TEST(FuzzCorpus, Hdf5ReadersGiveAFileOrAnH5Error) {
  run("h5", 3000, {}, [](const std::string& s) {
    manyrods::fuzz::h5_file(reinterpret_cast<const std::uint8_t*>(s.data()), s.size());
  });
}
