// host/scene/run/output_parts.cpp — a run's output in parts, so that a killed run
// loses at most one checkpoint interval (include/manyrods/runner.h
// "Checkpoints in parts"; docs/scenes.md "Checkpoints and --resume").
#include <algorithm>
#include <filesystem>
#include <vector>

#include "manyrods/runner.h"
#include "run/parts.h"

namespace manyrods::scene {

namespace fs = std::filesystem;

std::string parts_dir(const std::string& output) { return output + ".parts"; }

std::string part_path(const std::string& output, int k) {
  char name[32];
  std::snprintf(name, sizeof name, "part-%06d.h5", k);
  return (fs::path(parts_dir(output)) / name).string();
}

std::vector<std::string> list_parts(const std::string& output, bool remove_unfinished) {
  std::vector<std::string> parts;
  std::error_code ec;
  const fs::path dir = parts_dir(output);
  if (!fs::is_directory(dir, ec)) return parts;
  for (const fs::directory_entry& e : fs::directory_iterator(dir, ec)) {
    const std::string name = e.path().filename().string();
    if (name.size() == 14 && name.rfind("part-", 0) == 0 && name.substr(11) == ".h5") parts.push_back(e.path().string());
    else if (remove_unfinished && name.size() > 4 && name.substr(name.size() - 4) == ".tmp") fs::remove(e.path(), ec);
  }
  std::sort(parts.begin(), parts.end());
  // complete parts only: a part is renamed into place when its checkpoint is
  // written, so the names are 1 … N without gaps
  for (std::size_t i = 0; i < parts.size(); ++i)
    if (parts[i] != part_path(output, int(i) + 1))
      throw SceneError(parts_dir(output) + ": part " + std::to_string(i + 1) + " is missing (found " + parts[i] +
                       "); the parts cannot be continued");
  return parts;
}

std::int64_t merge_parts(const std::vector<std::string>& parts, const std::string& output, const h5::Layout& layout,
                         const h5::RunInfo& info, const h5::Checkpoint& last) {
  if (parts.size() == 1) {  // the part is the whole file
    std::error_code ec;
    fs::rename(parts[0], output, ec);
    if (ec) throw h5::H5Error(output + ": cannot move " + parts[0] + " to it: " + ec.message());
    const std::int64_t frames = h5::Reader(output).frames();
    fs::remove(parts_dir(output), ec);
    return frames;
  }
  h5::Writer w(output, layout, info);
  std::vector<double> x, q;
  std::vector<float> xf, qf;
  for (const std::string& p : parts) {
    const h5::Reader r(p);
    const h5::Output& o = r.output();
    if (o.nodes != layout.node_offsets.back())
      throw h5::H5Error(p + ": a part of another run (" + std::to_string(o.nodes) + " nodes, this run " +
                        std::to_string(layout.node_offsets.back()) + ")");
    for (std::int64_t f = 0; f < r.frames(); ++f) {
      r.read_positions(f, x);
      if (layout.directors) r.read_directors(f, q);
      const void* px = x.data();
      const void* pq = q.data();
      if (layout.float32) {  // float frames were stored as float: exact through double
        xf.assign(x.begin(), x.end());
        qf.assign(q.begin(), q.end());
        px = xf.data();
        pq = qf.data();
      }
      w.append_frame(o.time[std::size_t(f)], px, pq, o.energy[std::size_t(f)]);
    }
  }
  w.write_checkpoint(last);
  // a run's observables, written into its last part
  const std::vector<h5::Column> observables = h5::Reader(parts.back()).output().observables;
  if (!observables.empty()) w.write_observables(observables);
  w.finish();
  std::error_code ec;
  fs::remove_all(parts_dir(output), ec);
  return w.frames();
}

}  // namespace manyrods::scene
