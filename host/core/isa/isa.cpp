// host/core/isa/isa.cpp — the run-time choice between the builds of the step
// (include/manyrods/isa.h, host/core/isa/isa_table.h). The list of builds comes from
// CMake (MANYRODS_ISA) through the generated isa_paths.h:
//   MANYRODS_ISA_BASELINE        what the library itself was compiled for
//   MANYRODS_ISA_NATIVE          1 when that is -march=native
//   MANYRODS_ISA_VARIANTS(X)     X(id, "x86-64-vN") for every other build
#include <atomic>
#include <cstdlib>
#include <mutex>
#include <stdexcept>
#include <string>

#include "host/core/isa/isa_table.h"
#include "isa_paths.h"
#include "manyrods/isa.h"

#define MANYRODS_ISA_DECLARE(id, name) extern "C" const manyrods::isa::StepTable* manyrods_isa_table_##id();
MANYRODS_ISA_VARIANTS(MANYRODS_ISA_DECLARE)
#undef MANYRODS_ISA_DECLARE

namespace manyrods {
namespace {

struct Path {
  const char* name;
  const char* target;
  const isa::StepTable* (*table)();  // nullptr: the baseline's own code
};

#define MANYRODS_ISA_PATH(id, name) Path{name, name, &manyrods_isa_table_##id},
constexpr Path kPaths[] = {Path{"baseline", MANYRODS_ISA_BASELINE, nullptr}, MANYRODS_ISA_VARIANTS(MANYRODS_ISA_PATH)};
#undef MANYRODS_ISA_PATH

bool cpu_supports(const Path& p) {
  if (!p.table) return true;  // the process runs: the CPU has the baseline's instructions
#if defined(__x86_64__) && defined(__GNUC__)
  __builtin_cpu_init();
  const std::string n = p.name;
  if (n == "x86-64-v2") return __builtin_cpu_supports("x86-64-v2");
  if (n == "x86-64-v3") return __builtin_cpu_supports("x86-64-v3");
  if (n == "x86-64-v4") return __builtin_cpu_supports("x86-64-v4");
#endif
  return false;
}

std::string path_list() {
  std::string s;
  for (const Path& p : kPaths) {
    if (!s.empty()) s += ", ";
    s += p.name;
    if (!cpu_supports(p)) s += " (not on this CPU)";
  }
  return s;
}

// The automatic choice: the highest level the CPU runs (CMake lists them in
// ascending order), unless the baseline is -march=native.
int automatic() {
  int best = 0;
  if (!MANYRODS_ISA_NATIVE)
    for (int i = 1; i < int(std::size(kPaths)); ++i)
      if (cpu_supports(kPaths[i])) best = i;
  return best;
}

int find(const std::string& name, const char* what) {
  if (name == "auto") return automatic();
  for (int i = 0; i < int(std::size(kPaths)); ++i)
    if (name == kPaths[i].name) {
      if (!cpu_supports(kPaths[i]))
        throw std::invalid_argument(std::string(what) + "'" + name + "': this CPU cannot run it (step paths: " +
                                    path_list() + ")");
      return i;
    }
  throw std::invalid_argument(std::string(what) + "'" + name + "': not a step path of this build (step paths: " +
                              path_list() + ")");
}

std::atomic<int> g_active{-1};  // index into kPaths; -1 until the first step
std::mutex g_resolve;

int active_index() {
  int i = g_active.load(std::memory_order_acquire);
  if (i >= 0) return i;
  std::lock_guard<std::mutex> lock(g_resolve);
  i = g_active.load(std::memory_order_relaxed);
  if (i >= 0) return i;
  const char* env = std::getenv("MANYRODS_ISA");
  i = env && *env ? find(env, "MANYRODS_ISA=") : automatic();  // a bad value throws, every time
  g_active.store(i, std::memory_order_release);
  return i;
}

}  // namespace

const isa::StepTable* isa::active_table() {
  const Path& p = kPaths[active_index()];
  return p.table ? p.table() : nullptr;
}

std::vector<StepPath> step_paths() {
  int active = -1;
  try {
    active = active_index();
  } catch (const std::invalid_argument&) {  // a bad MANYRODS_ISA: none is active
  }
  std::vector<StepPath> out;
  for (int i = 0; i < int(std::size(kPaths)); ++i)
    out.push_back({kPaths[i].name, kPaths[i].target, cpu_supports(kPaths[i]), i == active});
  return out;
}

std::string active_step_path() { return kPaths[active_index()].name; }

void select_step_path(const std::string& name) {
  const int i = find(name, "select_step_path: ");
  std::lock_guard<std::mutex> lock(g_resolve);
  g_active.store(i, std::memory_order_release);
}

}  // namespace manyrods
