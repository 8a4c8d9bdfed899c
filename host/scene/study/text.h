// host/scene/study/text.h — the command-line specs' pieces (--vary, --fit,
// a measurements CSV): splitting at a separator, a number that must be the
// whole of its text.
//
// Reads and writes: nothing but its arguments.
#pragma once

#include <cmath>
#include <exception>
#include <sstream>
#include <string>
#include <vector>

#include "manyrods/scene.h"

namespace manyrods::scene {

// s cut at each c (an empty last piece where s ends with c)
inline std::vector<std::string> split(const std::string& s, char c) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  for (std::string p; std::getline(ss, p, c);) out.push_back(p);
  if (!s.empty() && s.back() == c) out.push_back("");
  return out;
}

// s as a finite number, all of it; SceneError "WHAT: 's' is not a finite
// number" otherwise
inline double finite_number(const std::string& s, const std::string& what) {
  std::size_t used = 0;
  double v = 0;
  try {
    v = std::stod(s, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != s.size() || !std::isfinite(v)) throw SceneError(what + ": '" + s + "' is not a finite number");
  return v;
}

}  // namespace manyrods::scene
