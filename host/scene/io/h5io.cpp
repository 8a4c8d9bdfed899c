// host/scene/io/h5io.cpp — HDF5 output, checkpoints and reading them back (include/manyrods/h5io.h).
#include "manyrods/h5io.h"

#include <hdf5.h>

#include <algorithm>
#include <iterator>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <sstream>
#include <string_view>
#include <utility>

namespace manyrods::h5 {
namespace {

constexpr int kFormatVersion = 2;  // 2: fixed-length strings, checksummed metadata and data

void quiet() {
  static const bool done = [] {
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);  // errors become exceptions, not stderr noise
    return true;
  }();
  (void)done;
}

// Owns one HDF5 identifier.
class Id {
 public:
  Id() = default;
  Id(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
  Id(Id&& o) noexcept : id_(o.id_), close_(o.close_) { o.id_ = -1; }
  Id& operator=(Id&& o) noexcept {
    if (this != &o) {
      reset();
      id_ = o.id_;
      close_ = o.close_;
      o.id_ = -1;
    }
    return *this;
  }
  ~Id() { reset(); }
  void reset() {
    if (id_ >= 0 && close_) close_(id_);
    id_ = -1;
  }
  hid_t get() const { return id_; }
  bool ok() const { return id_ >= 0; }

 private:
  hid_t id_ = -1;
  herr_t (*close_)(hid_t) = nullptr;
};

[[noreturn]] void fail(const std::string& path, const std::string& what) {
  throw H5Error(path + ": " + what);
}

Id checked(hid_t id, herr_t (*close)(hid_t), const std::string& path, const std::string& what) {
  if (id < 0) fail(path, what);
  return Id(id, close);
}
void check(herr_t e, const std::string& path, const std::string& what) {
  if (e < 0) fail(path, what);
}

// Strings are fixed-length attributes (UTF-8, null-padded, at least one
// byte): a variable-length string lives in the file's global heap, whose
// damaged entries crash libhdf5 while reading (H5HG_read), where a
// fixed-length one is plain bytes of a known size.
Id string_type(std::size_t n) {
  Id t(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(t.get(), std::max<std::size_t>(1, n));
  H5Tset_strpad(t.get(), H5T_STR_NULLPAD);
  H5Tset_cset(t.get(), H5T_CSET_UTF8);
  return t;
}

void attr_string(hid_t obj, const char* name, const std::string& value, const std::string& path) {
  const Id t = string_type(value.size());
  const Id sp(H5Screate(H5S_SCALAR), H5Sclose);
  const Id a = checked(H5Acreate2(obj, name, t.get(), sp.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose, path,
                       std::string("cannot create attribute ") + name);
  std::string buf = value;
  buf.resize(std::max<std::size_t>(1, value.size()), '\0');
  check(H5Awrite(a.get(), t.get(), buf.data()), path, std::string("cannot write attribute ") + name);
}

template <class V>
void attr_scalar(hid_t obj, const char* name, V value, hid_t type, const std::string& path) {
  const Id sp(H5Screate(H5S_SCALAR), H5Sclose);
  const Id a = checked(H5Acreate2(obj, name, type, sp.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose, path,
                       std::string("cannot create attribute ") + name);
  check(H5Awrite(a.get(), type, &value), path, std::string("cannot write attribute ") + name);
}

bool has_attr(hid_t obj, const char* name) { return H5Aexists(obj, name) > 0; }

std::string read_attr_string(hid_t obj, const char* name, const std::string& path, const std::string& where) {
  if (!has_attr(obj, name)) fail(path, "missing attribute " + where + name);
  const Id a =
      checked(H5Aopen(obj, name, H5P_DEFAULT), H5Aclose, path, "cannot open attribute " + where + name);
  const Id ft = checked(H5Aget_type(a.get()), H5Tclose, path, "cannot read the type of attribute " + where + name);
  if (H5Tget_class(ft.get()) != H5T_STRING) fail(path, "attribute " + where + name + " is not a string");
  // not read: a variable-length string is read from the global heap (see string_type)
  if (H5Tis_variable_str(ft.get()) != 0)
    fail(path, "attribute " + where + name +
                   " is a variable-length string (not written by this manyrods, or damaged); not read");
  const Id sp = checked(H5Aget_space(a.get()), H5Sclose, path, "cannot read the shape of attribute " + where + name);
  if (H5Sget_simple_extent_npoints(sp.get()) != 1) fail(path, "attribute " + where + name + " is not a single string");
  const std::size_t n = H5Tget_size(ft.get());
  if (n == 0 || n > (std::size_t(1) << 26)) fail(path, "attribute " + where + name + " has an impossible size (damaged?)");
  std::string s(n, '\0');
  const Id t = string_type(n);
  check(H5Aread(a.get(), t.get(), s.data()), path, "cannot read attribute " + where + name);
  s.resize(std::strlen(s.c_str()));
  return s;
}

template <class V>
V read_attr_scalar(hid_t obj, const char* name, hid_t type, const std::string& path,
                   const std::string& where) {
  if (!has_attr(obj, name)) fail(path, "missing attribute " + where + name);
  const Id a =
      checked(H5Aopen(obj, name, H5P_DEFAULT), H5Aclose, path, "cannot open attribute " + where + name);
  V v{};
  check(H5Aread(a.get(), type, &v), path, "cannot read attribute " + where + name);
  return v;
}

bool deflate_available() { return H5Zfilter_avail(H5Z_FILTER_DEFLATE) > 0; }

// A chunked, compressed dataset; dims[0] unlimited when `extendable`.
Id create_dataset(hid_t loc, const char* name, hid_t type, const std::vector<hsize_t>& dims,
                  const std::vector<hsize_t>& chunk, bool extendable, const std::string& path) {
  std::vector<hsize_t> maxdims = dims;
  if (extendable) maxdims[0] = H5S_UNLIMITED;
  const Id sp = checked(H5Screate_simple(int(dims.size()), dims.data(), maxdims.data()), H5Sclose, path,
                        std::string("cannot create dataspace for ") + name);
  const Id pl(H5Pcreate(H5P_DATASET_CREATE), H5Pclose);
  check(H5Pset_chunk(pl.get(), int(chunk.size()), chunk.data()), path, std::string("bad chunk for ") + name);
  if (deflate_available()) {
    H5Pset_shuffle(pl.get());
    H5Pset_deflate(pl.get(), 4);
  }
  // a checksum per chunk: damaged data is a read error, not a silent state
  check(H5Pset_fletcher32(pl.get()), path, std::string("cannot add a checksum to ") + name);
  return checked(H5Dcreate2(loc, name, type, sp.get(), H5P_DEFAULT, pl.get(), H5P_DEFAULT), H5Dclose, path,
                 std::string("cannot create dataset ") + name);
}

template <class V>
void write_vector(hid_t loc, const char* name, hid_t type, const std::vector<V>& v, const std::string& path) {
  const std::vector<hsize_t> dims{hsize_t(v.size())};
  const std::vector<hsize_t> chunk{std::max<hsize_t>(1, std::min<hsize_t>(v.size(), 1 << 16))};
  const Id d = create_dataset(loc, name, type, dims, chunk, false, path);
  if (!v.empty())
    check(H5Dwrite(d.get(), type, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()), path,
          std::string("cannot write ") + name);
}

// Appends one row (all but the first dimension) to an extendable dataset.
void append_row(hid_t d, hid_t type, std::int64_t row, const std::vector<hsize_t>& tail, const void* data,
                const std::string& path, const char* name) {
  std::vector<hsize_t> dims{hsize_t(row + 1)};
  dims.insert(dims.end(), tail.begin(), tail.end());
  check(H5Dset_extent(d, dims.data()), path, std::string("cannot extend ") + name);
  const Id fs(H5Dget_space(d), H5Sclose);
  std::vector<hsize_t> start(dims.size(), 0), count = dims;
  start[0] = hsize_t(row);
  count[0] = 1;
  check(H5Sselect_hyperslab(fs.get(), H5S_SELECT_SET, start.data(), nullptr, count.data(), nullptr), path,
        std::string("cannot select a row of ") + name);
  const Id ms(H5Screate_simple(int(count.size()), count.data(), nullptr), H5Sclose);
  check(H5Dwrite(d, type, ms.get(), fs.get(), H5P_DEFAULT, data), path, std::string("cannot write ") + name);
}

std::vector<hsize_t> dataset_dims(hid_t d) {
  const Id sp(H5Dget_space(d), H5Sclose);
  const int rank = H5Sget_simple_extent_ndims(sp.get());
  std::vector<hsize_t> dims(std::max(rank, 0));
  if (rank > 0) H5Sget_simple_extent_dims(sp.get(), dims.data(), nullptr);
  return dims;
}

std::string dims_str(const std::vector<hsize_t>& d) {
  std::string s = "[";
  for (std::size_t i = 0; i < d.size(); ++i) s += (i ? ", " : "") + std::to_string(d[i]);
  return s + "]";
}

Id open_dataset(hid_t loc, const char* name, const std::string& path) {
  if (H5Lexists(loc, name, H5P_DEFAULT) <= 0) fail(path, std::string("missing dataset ") + name);
  return checked(H5Dopen2(loc, name, H5P_DEFAULT), H5Dclose, path,
                 std::string("cannot open dataset ") + name);
}

// A size read from the file, before memory is taken for it: no more than
// the file could hold (deflate expands at most ~1,032×), so that a damaged
// size is an error, not an allocation of terabytes.
void plausible(const std::string& path, const std::string& what, double count, double element_bytes) {
  std::error_code ec;
  const double file = double(std::filesystem::file_size(path, ec));
  const double limit = (ec ? 0.0 : file) * 1100.0 + 64e6;
  if (!(count >= 0) || !(count * element_bytes <= limit))
    fail(path, what + ": " + std::to_string(count) + " entries, more than this file can hold (damaged?)");
}

template <class V>
std::vector<V> read_vector(hid_t loc, const char* name, hid_t type, const std::string& path) {
  const Id d = open_dataset(loc, name, path);
  const auto dims = dataset_dims(d.get());
  if (dims.size() != 1) fail(path, std::string(name) + " has shape " + dims_str(dims) + ", expected 1-D");
  plausible(path, name, double(dims[0]), sizeof(V));
  std::vector<V> v(dims[0]);
  if (!v.empty())
    check(H5Dread(d.get(), type, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()), path,
          std::string("cannot read ") + name + " (truncated or damaged file?)");
  return v;
}

// Opens a manyrods file read-only with clear errors for the usual problems.
// The file, checked to be a manyrods file of this version whose root
// attribute format is `format` ("manyrods": an output, or a sweep's index).
Id open_manyrods(const std::string& path, const std::string& format = "manyrods") {
  quiet();
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) fail(path, "no such file");
  if (H5Fis_hdf5(path.c_str()) <= 0) fail(path, "not an HDF5 file (no HDF5 signature)");
  Id f(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!f.ok()) fail(path, "cannot open this HDF5 file (truncated or damaged?)");
  if (!has_attr(f.get(), "format") || !has_attr(f.get(), "format_version"))
    fail(path, "an HDF5 file, but not a manyrods output (no root attributes format, format_version)");
  // the version first: version 1 files hold variable-length strings, which are not read (string_type)
  const auto v = read_attr_scalar<std::int64_t>(f.get(), "format_version", H5T_NATIVE_INT64, path, "/");
  if (v != kFormatVersion)
    fail(path, "format_version " + std::to_string(v) + ", this manyrods reads " + std::to_string(kFormatVersion) +
                   (v == 1 ? " (version 1 files, from before 2026-12-02, are not read: rerun the scene)" : ""));
  const std::string found = read_attr_string(f.get(), "format", path, "/");
  if (found != format)
    fail(path, format == "manyrods" && found == "manyrods-sweep-index"
                   ? "a chunked sweep's index, not a run's output (its frames are in its chunk files)"
                   : "an HDF5 file, but not a manyrods " + std::string(format == "manyrods" ? "output" : "sweep index") +
                         " (root attribute format is not \"" + format + "\")");
  return f;
}

// A group of columns (column_group), in the order of its attribute.
std::vector<Column> read_column_group(hid_t f, const std::string& gp, const std::string& path) {
  std::vector<Column> out;
  const Id g = checked(H5Gopen2(f, gp.c_str(), H5P_DEFAULT), H5Gclose, path, "missing group /" + gp);
  std::stringstream ss(read_attr_string(g.get(), "order", path, "/" + gp + "."));
  for (std::string n; std::getline(ss, n);)
    out.push_back({n, read_vector<double>(g.get(), n.c_str(), H5T_NATIVE_DOUBLE, path)});
  return out;
}

// The /energy datasets of a frame: step.h's energy list by dataset name, then
// the run's dissipated energy (EnergyRow::dissipated).
struct EnergyDataset {
  const char* name;
  bool contact_only;
  double EnergyRow::* member;
};
#define MANYRODS_ENERGY_DATASET(name, dataset, unit, written, doc) \
  EnergyDataset{dataset, std::string_view(#written) == "contact", &EnergyRow::name},
constexpr EnergyDataset kEnergyDatasets[] = {MANYRODS_ENERGY_FIELDS(MANYRODS_ENERGY_DATASET){
    "dissipated", false, &EnergyRow::dissipated}};
#undef MANYRODS_ENERGY_DATASET
constexpr int kEnergies = int(std::size(kEnergyDatasets));

}  // namespace

// ---- Writer ------------------------------------------------------------------

struct Writer::Impl {
  std::string path, tmp;
  Layout layout;
  Id file, time, pos, dir, energy_group, contact_group;
  Id energy[kEnergies], contact_count, contact_depth;
  std::int64_t frames = 0, nodes = 0, elements = 0;
  bool closed = false;

  hid_t real_type() const { return layout.float32 ? H5T_NATIVE_FLOAT : H5T_NATIVE_DOUBLE; }
  void close() {
    for (auto& e : energy) e.reset();
    contact_count.reset();
    contact_depth.reset();
    contact_group.reset();
    energy_group.reset();
    dir.reset();
    pos.reset();
    time.reset();
    if (file.ok()) H5Fflush(file.get(), H5F_SCOPE_GLOBAL);
    file.reset();
    closed = true;
  }
};

Writer::Writer(const std::string& path, const Layout& layout, const RunInfo& info) : impl_(new Impl) {
  quiet();
  Impl& w = *impl_;
  w.path = path;
  w.tmp = path + ".tmp";
  w.layout = layout;
  if (layout.node_offsets.size() < 2 || layout.element_offsets.size() != layout.node_offsets.size())
    fail(path, "writer: bad layout (no rods)");
  w.nodes = layout.node_offsets.back();
  w.elements = layout.element_offsets.back();
  // the 1.10 file format: checksums on the superblock, object headers and
  // B-trees, so that damaged metadata is an error when read
  const Id fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
  check(H5Pset_libver_bounds(fapl.get(), H5F_LIBVER_V110, H5F_LIBVER_LATEST), w.tmp, "cannot set the file format");
  w.file = checked(H5Fcreate(w.tmp.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, fapl.get()), H5Fclose, w.tmp,
                   "cannot create the output file (directory missing or not writable?)");
  const hid_t f = w.file.get();
  attr_string(f, "format", "manyrods", w.tmp);
  attr_scalar<std::int64_t>(f, "format_version", kFormatVersion, H5T_NATIVE_INT64, w.tmp);
  attr_string(f, "precision", layout.float32 ? "float" : "double", w.tmp);
  attr_string(f, "integrator", info.integrator, w.tmp);
  attr_scalar<double>(f, "dt", info.dt, H5T_NATIVE_DOUBLE, w.tmp);
  {
    const Id g = checked(H5Gcreate2(f, "scene", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose, w.tmp,
                         "cannot create /scene");
    attr_string(g.get(), "text", info.scene_text, w.tmp);
    attr_string(g.get(), "source", info.scene_source, w.tmp);
  }
  write_vector(f, "node_offsets", H5T_NATIVE_INT64, layout.node_offsets, w.tmp);
  write_vector(f, "element_offsets", H5T_NATIVE_INT64, layout.element_offsets, w.tmp);
  {
    const Id g = checked(H5Gcreate2(f, "rods", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose, w.tmp,
                         "cannot create /rods");
    write_vector(g.get(), "group", H5T_NATIVE_INT32, layout.rod_group, w.tmp);
    write_vector(g.get(), "width", H5T_NATIVE_DOUBLE, layout.rod_width, w.tmp);
    if (!layout.node_width.empty()) write_vector(g.get(), "node_width", H5T_NATIVE_DOUBLE, layout.node_width, w.tmp);
    std::string names;
    for (std::size_t i = 0; i < layout.group_names.size(); ++i)
      names += (i ? "\n" : "") + layout.group_names[i];
    attr_string(g.get(), "group_names", names, w.tmp);
  }
  const hsize_t nc = std::min<hsize_t>(hsize_t(w.nodes), 1 << 16),
                ec = std::min<hsize_t>(hsize_t(w.elements), 1 << 14);
  w.time = create_dataset(f, "time", H5T_NATIVE_DOUBLE, {0}, {1024}, true, w.tmp);
  w.pos =
      create_dataset(f, fields::public_name::node_x, w.real_type(), {0, hsize_t(w.nodes), 3}, {1, nc, 3}, true, w.tmp);
  if (layout.directors)
    w.dir = create_dataset(f, fields::public_name::elem_Q, w.real_type(), {0, hsize_t(w.elements), 3, 3},
                           {1, ec, 3, 3}, true, w.tmp);
  w.energy_group = checked(H5Gcreate2(f, "energy", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose, w.tmp,
                           "cannot create /energy");
  for (int i = 0; i < kEnergies; ++i)
    if (layout.contact || !kEnergyDatasets[i].contact_only)
      w.energy[i] = create_dataset(w.energy_group.get(), kEnergyDatasets[i].name, H5T_NATIVE_DOUBLE, {0}, {1024},
                                   true, w.tmp);
  {
    std::string units;
#define MANYRODS_ENERGY_UNIT(name, dataset, unit, written, doc) units += std::string(dataset) + ": " unit "; ";
    MANYRODS_ENERGY_FIELDS(MANYRODS_ENERGY_UNIT)
#undef MANYRODS_ENERGY_UNIT
    attr_string(w.energy_group.get(), "units", units + "dissipated: J", w.tmp);
  }
  if (layout.contact) {
    w.contact_group = checked(H5Gcreate2(f, "contact", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose, w.tmp,
                              "cannot create /contact");
    w.contact_count = create_dataset(w.contact_group.get(), "count", H5T_NATIVE_DOUBLE, {0}, {1024}, true, w.tmp);
    w.contact_depth =
        create_dataset(w.contact_group.get(), "max_penetration", H5T_NATIVE_DOUBLE, {0}, {1024}, true, w.tmp);
    attr_string(w.contact_group.get(), "units", "count: contacts in touch; max_penetration: m", w.tmp);
  }
}

Writer::~Writer() {
  if (impl_ && !impl_->closed) {
    impl_->close();
    std::remove(impl_->tmp.c_str());
  }
}

void Writer::append_frame(double t, const void* positions, const void* directors, const EnergyRow& e) {
  Impl& w = *impl_;
  append_row(w.time.get(), H5T_NATIVE_DOUBLE, w.frames, {}, &t, w.tmp, "time");
  append_row(w.pos.get(), w.real_type(), w.frames, {hsize_t(w.nodes), 3}, positions, w.tmp, fields::public_name::node_x);
  if (w.layout.directors)
    append_row(w.dir.get(), w.real_type(), w.frames, {hsize_t(w.elements), 3, 3}, directors, w.tmp,
               fields::public_name::elem_Q);
  for (int i = 0; i < kEnergies; ++i)
    if (w.energy[i].ok())
      append_row(w.energy[i].get(), H5T_NATIVE_DOUBLE, w.frames, {}, &(e.*kEnergyDatasets[i].member), w.tmp,
                 kEnergyDatasets[i].name);
  if (w.layout.contact) {
    append_row(w.contact_count.get(), H5T_NATIVE_DOUBLE, w.frames, {}, &e.contacts, w.tmp, "contact/count");
    append_row(w.contact_depth.get(), H5T_NATIVE_DOUBLE, w.frames, {}, &e.max_penetration, w.tmp,
               "contact/max_penetration");
  }
  ++w.frames;
}

void Writer::write_checkpoint(const Checkpoint& c) {
  Impl& w = *impl_;
  const hid_t f = w.file.get();
  if (H5Lexists(f, "checkpoint", H5P_DEFAULT) > 0) H5Ldelete(f, "checkpoint", H5P_DEFAULT);
  const Id g = checked(H5Gcreate2(f, "checkpoint", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose, w.tmp,
                       "cannot create /checkpoint");
  attr_string(g.get(), "precision", c.float32 ? "float" : "double", w.tmp);
  attr_scalar<std::int64_t>(g.get(), "slots", c.slots, H5T_NATIVE_INT64, w.tmp);
  attr_scalar<double>(g.get(), "time", c.time, H5T_NATIVE_DOUBLE, w.tmp);
  attr_scalar<double>(g.get(), "dt", c.dt, H5T_NATIVE_DOUBLE, w.tmp);
  attr_scalar<std::int64_t>(g.get(), "steps", c.steps, H5T_NATIVE_INT64, w.tmp);
  attr_scalar<double>(g.get(), "dissipated", c.dissipated, H5T_NATIVE_DOUBLE, w.tmp);
  attr_scalar<double>(g.get(), "last_dissipation_rate", c.last_rate, H5T_NATIVE_DOUBLE, w.tmp);
  attr_scalar<double>(g.get(), "validity_energy0", c.validity_energy0, H5T_NATIVE_DOUBLE, w.tmp);
  attr_scalar<double>(g.get(), "validity_scale", c.validity_scale, H5T_NATIVE_DOUBLE, w.tmp);
  attr_scalar<std::int64_t>(g.get(), "frames_written", c.frames_written, H5T_NATIVE_INT64, w.tmp);
  const hid_t type = c.float32 ? H5T_NATIVE_FLOAT : H5T_NATIVE_DOUBLE;
  const std::size_t es = c.float32 ? 4 : 8;
  auto put = [&](const char* name, const std::vector<unsigned char>& bytes, hsize_t rows) {
    if (bytes.size() != rows * std::size_t(c.slots) * es)
      fail(w.tmp, std::string("checkpoint: wrong size of ") + name);
    const hsize_t chunk = std::max<hsize_t>(1, std::min<hsize_t>(hsize_t(c.slots), 1 << 16));
    const Id d = create_dataset(g.get(), name, type, {rows, hsize_t(c.slots)}, {1, chunk}, false, w.tmp);
    check(H5Dwrite(d.get(), type, H5S_ALL, H5S_ALL, H5P_DEFAULT, bytes.data()), w.tmp,
          std::string("cannot write checkpoint/") + name);
  };
#define MANYRODS_PUT(name, n, fill, float_only, doc) \
  if (!(float_only) || !c.name.empty()) put(#name, c.name, n);
  MANYRODS_STATE_FIELDS(MANYRODS_PUT)
#undef MANYRODS_PUT
  if (!c.contact_work.empty()) put("contact_work", c.contact_work, 1);
  if (!c.contact_impulses.empty()) {
    constexpr hsize_t cols = Checkpoint::kContactImpulseColumns;
    if (c.contact_impulses.size() % cols != 0) fail(w.tmp, "checkpoint: wrong size of contact_impulses");
    const hsize_t rows = c.contact_impulses.size() / cols;
    const Id d = create_dataset(g.get(), "contact_impulses", H5T_NATIVE_DOUBLE, {rows, cols},
                                {std::min<hsize_t>(rows, 1 << 12), cols}, false, w.tmp);
    check(H5Dwrite(d.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, c.contact_impulses.data()), w.tmp,
          "cannot write checkpoint/contact_impulses");
  }
  if (c.probe_count > 0) {
    const hsize_t p = hsize_t(c.probe_count), n = hsize_t(c.probe_samples);
    if (c.probe_time.size() != p * n || c.probe_tip.size() != p * n * 3 || c.probe_max_strain.size() != p ||
        c.probe_dissipated.size() != p || c.probe_rate.size() != p)
      fail(w.tmp, "checkpoint: inconsistent probe records");
    const Id pg = checked(H5Gcreate2(g.get(), "probes", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose, w.tmp,
                          "cannot create /checkpoint/probes");
    auto put_d = [&](const char* name, const std::vector<double>& v, std::vector<hsize_t> dims) {
      std::vector<hsize_t> chunk = dims;
      for (hsize_t& c2 : chunk) c2 = std::max<hsize_t>(1, std::min<hsize_t>(c2, 1 << 12));
      const Id d = create_dataset(pg.get(), name, H5T_NATIVE_DOUBLE, dims, chunk, false, w.tmp);
      if (!v.empty())
        check(H5Dwrite(d.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()), w.tmp,
              std::string("cannot write checkpoint/probes/") + name);
    };
    put_d("time", c.probe_time, {p, n});
    put_d("tip", c.probe_tip, {p, n, 3});
    put_d("max_strain", c.probe_max_strain, {p});
    put_d("dissipated", c.probe_dissipated, {p});
    put_d("dissipation_rate", c.probe_rate, {p});
    if (!c.probe_observed.empty() || !c.probe_observed_last.empty()) {
      if (c.probe_observed.size() % p != 0 || c.probe_observed_last.size() % p != 0)
        fail(w.tmp, "checkpoint: inconsistent observable records");
      put_d("observed", c.probe_observed, {p, c.probe_observed.size() / p});
      put_d("observed_last", c.probe_observed_last, {p, c.probe_observed_last.size() / p});
    }
    if (!c.probe_failed_at.empty()) {
      if (c.probe_failed_at.size() != p) fail(w.tmp, "checkpoint: inconsistent failure records");
      put_d("failed_at", c.probe_failed_at, {p});
    }
  }
}

namespace {
// /loc/name: one dataset per column, their names in the attribute "order".
Id column_group(hid_t loc, const char* name, const std::vector<Column>& cols, const std::string& path) {
  Id sg = checked(H5Gcreate2(loc, name, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose, path,
                  std::string("cannot create the group ") + name);
  std::string order;
  for (const Column& c : cols) {
    write_vector(sg.get(), c.name.c_str(), H5T_NATIVE_DOUBLE, c.values, path);
    order += (order.empty() ? "" : "\n") + c.name;
  }
  attr_string(sg.get(), "order", order, path);
  return sg;
}
std::string lines(const std::vector<std::string>& v) {
  std::string s;
  for (const std::string& x : v) s += (s.empty() ? "" : "\n") + x;
  return s;
}
}  // namespace

void Writer::add_sweep_table(const char* name, const std::vector<Column>& columns, const char* rows_attr,
                             const std::vector<std::string>& row_names) {
  Impl& w = *impl_;
  const Id g = checked(H5Gopen2(w.file.get(), "sweep", H5P_DEFAULT), H5Gclose, w.tmp, "no /sweep to add to");
  const Id t = column_group(g.get(), name, columns, w.tmp);
  attr_string(t.get(), rows_attr, lines(row_names), w.tmp);
}

void Writer::write_table(const char* name, const std::vector<Column>& columns, const char* rows_attr,
                         const std::vector<std::string>& row_names) {
  Impl& w = *impl_;
  const Id t = column_group(w.file.get(), name, columns, w.tmp);
  if (rows_attr) attr_string(t.get(), rows_attr, lines(row_names), w.tmp);
}

void Writer::write_sweep(const std::vector<Column>& parameters, const std::vector<Column>& summary,
                         const std::vector<std::int32_t>& variation_first_rod, int sensitivity_base) {
  Impl& w = *impl_;
  const Id g = checked(H5Gcreate2(w.file.get(), "sweep", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose,
                       w.tmp, "cannot create /sweep");
  if (sensitivity_base > 0)
    attr_scalar<std::int64_t>(g.get(), "sensitivity_base", sensitivity_base, H5T_NATIVE_INT64, w.tmp);
  write_vector(g.get(), "variation_first_rod", H5T_NATIVE_INT32, variation_first_rod, w.tmp);
  column_group(g.get(), "parameters", parameters, w.tmp);
  column_group(g.get(), "summary", summary, w.tmp);
}

void Writer::write_holds(const Holds& h) {
  Impl& w = *impl_;
  const std::size_t n = h.rod.size();
  if (h.node.size() != n || h.clamped.size() != n || h.force.size() != 3 * n || h.moment.size() != 3 * n)
    fail(w.tmp, "holds: the columns differ in length");
  const Id g = checked(H5Gcreate2(w.file.get(), "holds", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose, w.tmp,
                       "cannot create /holds");
  write_vector(g.get(), "rod", H5T_NATIVE_INT32, h.rod, w.tmp);
  write_vector(g.get(), "node", H5T_NATIVE_INT32, h.node, w.tmp);
  write_vector(g.get(), "clamped", H5T_NATIVE_INT8, h.clamped, w.tmp);
  for (const auto& [name, v] : {std::pair<const char*, const std::vector<double>*>{"force", &h.force}, {"moment", &h.moment}}) {
    const Id d = create_dataset(g.get(), name, H5T_NATIVE_DOUBLE, {hsize_t(n), 3}, {std::max<hsize_t>(1, hsize_t(n)), 3},
                                false, w.tmp);
    if (n > 0)
      check(H5Dwrite(d.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v->data()), w.tmp,
            std::string("cannot write /holds/") + name);
  }
  attr_string(g.get(), "units", "force N, moment N m, lab frame: what each hold exerts on its rod", w.tmp);
  const Id st = checked(H5Gcreate2(w.file.get(), "static", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose, w.tmp,
                        "cannot create /static");
  attr_scalar<double>(st.get(), "time", h.time, H5T_NATIVE_DOUBLE, w.tmp);
  attr_scalar<double>(st.get(), "residual_force", h.residual_force, H5T_NATIVE_DOUBLE, w.tmp);
  attr_scalar<double>(st.get(), "residual_couple", h.residual_couple, H5T_NATIVE_DOUBLE, w.tmp);
  attr_scalar<std::int64_t>(st.get(), "newton_iterations", h.iterations, H5T_NATIVE_INT64, w.tmp);
  attr_scalar<std::int64_t>(st.get(), "load_increments", h.load_increments, H5T_NATIVE_INT64, w.tmp);
}

void Writer::write_observables(const std::vector<Column>& columns) {
  column_group(impl_->file.get(), "observables", columns, impl_->tmp);
}

std::int64_t Writer::frames() const { return impl_->frames; }
const std::string& Writer::path() const { return impl_->path; }

void Writer::finish() {
  Impl& w = *impl_;
  if (w.closed) return;
  w.close();
  std::error_code ec;
  std::filesystem::rename(w.tmp, w.path, ec);
  if (ec) fail(w.path, "cannot rename " + w.tmp + " to it: " + ec.message());
}

// ---- reading -----------------------------------------------------------------

namespace {
// /name [frames, Σ rows, …] (width = 3: [.., 3]; 9: [.., 3, 3]), a virtual
// dataset whose rows [o_k, o_k + rows_k) are /name of file k (a path
// relative to the index's folder, where HDF5 looks for it), NaN where a
// file is missing.
void virtual_concat(hid_t loc, const char* name, hid_t type, std::size_t frames, const std::vector<std::string>& files,
                    const std::vector<std::int64_t>& rows, int width, const std::string& path) {
  hsize_t total = 0;
  for (std::int64_t r : rows) total += hsize_t(r);
  std::vector<hsize_t> dims{hsize_t(frames), total, 3};
  if (width == 9) dims.push_back(3);
  const Id vs = checked(H5Screate_simple(int(dims.size()), dims.data(), nullptr), H5Sclose, path,
                        std::string("cannot create the dataspace of ") + name);
  const Id pl(H5Pcreate(H5P_DATASET_CREATE), H5Pclose);
  const double nan = NAN;
  const float nanf = NAN;
  check(H5Pset_fill_value(pl.get(), type, type == H5T_NATIVE_FLOAT ? static_cast<const void*>(&nanf) : &nan), path,
        std::string("cannot set the fill value of ") + name);
  hsize_t at = 0;
  for (std::size_t k = 0; k < files.size(); ++k) {
    std::vector<hsize_t> src = dims, start(dims.size(), 0);
    src[1] = hsize_t(rows[k]);
    start[1] = at;
    at += hsize_t(rows[k]);
    if (rows[k] == 0) continue;
    const Id ss = checked(H5Screate_simple(int(src.size()), src.data(), nullptr), H5Sclose, path,
                          std::string("cannot create a source dataspace of ") + name);
    check(H5Sselect_hyperslab(vs.get(), H5S_SELECT_SET, start.data(), nullptr, src.data(), nullptr), path,
          std::string("cannot select the rows of ") + files[k] + " in " + name);
    check(H5Pset_virtual(pl.get(), vs.get(), files[k].c_str(), name, ss.get()), path,
          std::string("cannot map ") + files[k] + " into " + name);
  }
  H5Sselect_none(vs.get());
  checked(H5Dcreate2(loc, name, type, vs.get(), H5P_DEFAULT, pl.get(), H5P_DEFAULT), H5Dclose, path,
          std::string("cannot create the virtual dataset ") + name);
}
}  // namespace

void write_sweep_index(const std::string& path, const SweepIndex& x) {
  const std::string tmp = path + ".tmp";
  {
    const Id fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
    check(H5Pset_libver_bounds(fapl.get(), H5F_LIBVER_V110, H5F_LIBVER_LATEST), tmp, "cannot set the file format");
    const Id f = checked(H5Fcreate(tmp.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, fapl.get()), H5Fclose, tmp,
                         "cannot create the sweep index (directory missing or not writable?)");
    attr_string(f.get(), "format", "manyrods-sweep-index", tmp);
    attr_scalar<std::int64_t>(f.get(), "format_version", kFormatVersion, H5T_NATIVE_INT64, tmp);
    attr_scalar<double>(f.get(), "dt", x.dt, H5T_NATIVE_DOUBLE, tmp);
    {
      const Id g = checked(H5Gcreate2(f.get(), "scene", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose, tmp,
                           "cannot create /scene");
      attr_string(g.get(), "text", x.scene_text, tmp);
      attr_string(g.get(), "source", x.scene_source, tmp);
    }
    const Id g = checked(H5Gcreate2(f.get(), "sweep", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose, tmp,
                         "cannot create /sweep");
    column_group(g.get(), "parameters", x.parameters, tmp);
    column_group(g.get(), "summary", x.summary, tmp);
    const Id st = column_group(g.get(), "statistics", x.statistics, tmp);
    attr_string(st.get(), "statistics", lines(x.statistic_names), tmp);
    if (!x.sensitivity.empty()) {
      const Id se = column_group(g.get(), "sensitivity", x.sensitivity, tmp);
      attr_string(se.get(), "indices", lines(x.sensitivity_names), tmp);
    }
    attr_string(g.get(), "chunk_files", lines(x.chunk_files), tmp);
    write_vector(g.get(), "chunk_first_variation", H5T_NATIVE_INT64, x.chunk_first, tmp);
    if (!x.chunk_nodes.empty() && !x.time.empty()) {  // (a sweep without frames: none to present)
      if (x.chunk_nodes.size() != x.chunk_files.size() || x.chunk_elements.size() != x.chunk_files.size())
        fail(tmp, "sweep index: chunk sizes do not match the chunk files");
      write_vector(f.get(), "time", H5T_NATIVE_DOUBLE, x.time, tmp);
      write_vector(f.get(), "node_offsets", H5T_NATIVE_INT64, x.node_offsets, tmp);
      write_vector(f.get(), "element_offsets", H5T_NATIVE_INT64, x.element_offsets, tmp);
      const hid_t type = x.float32 ? H5T_NATIVE_FLOAT : H5T_NATIVE_DOUBLE;
      virtual_concat(f.get(), fields::public_name::node_x, type, x.time.size(), x.chunk_files, x.chunk_nodes, 3, tmp);
      if (x.directors)
        virtual_concat(f.get(), fields::public_name::elem_Q, type, x.time.size(), x.chunk_files, x.chunk_elements, 9, tmp);
    }
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) fail(path, "cannot rename " + tmp + " to it: " + ec.message());
}

bool is_sweep_index(const std::string& path) {
  quiet();
  std::error_code ec;
  if (!std::filesystem::exists(path, ec) || H5Fis_hdf5(path.c_str()) <= 0) return false;
  const Id f(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  return f.ok() && has_attr(f.get(), "format") &&
         read_attr_string(f.get(), "format", path, "/") == "manyrods-sweep-index";
}

SweepIndex read_sweep_index(const std::string& path) {
  const Id f = open_manyrods(path, "manyrods-sweep-index");
  SweepIndex x;
  x.parameters = read_column_group(f.get(), "sweep/parameters", path);
  x.summary = read_column_group(f.get(), "sweep/summary", path);
  x.statistics = read_column_group(f.get(), "sweep/statistics", path);
  const std::size_t n = x.parameters.empty() ? 0 : x.parameters[0].values.size();
  for (const auto* cols : {&x.parameters, &x.summary})
    for (const Column& c : *cols)
      if (c.values.size() != n)
        fail(path, "/sweep/" + std::string(cols == &x.parameters ? "parameters/" : "summary/") + c.name + " has " +
                       std::to_string(c.values.size()) + " values, " + std::to_string(n) + " variations expected");
  const Id sg = checked(H5Gopen2(f.get(), "scene", H5P_DEFAULT), H5Gclose, path, "missing group /scene");
  x.scene_text = read_attr_string(sg.get(), "text", path, "/scene.");
  x.scene_source = read_attr_string(sg.get(), "source", path, "/scene.");
  x.dt = read_attr_scalar<double>(f.get(), "dt", H5T_NATIVE_DOUBLE, path, "/");
  return x;
}

namespace {
// /checkpoint's attributes and /scene: the run's precision, size, time and
// bookkeeping, and the scene it ran.
void read_checkpoint_run(hid_t f, hid_t g, const std::string& path, Checkpoint& c) {
  const std::string where = "/checkpoint.";
  const std::string prec = read_attr_string(g, "precision", path, where);
  if (prec != "float" && prec != "double") fail(path, "/checkpoint.precision is \"" + prec + "\"");
  c.float32 = prec == "float";
  c.slots = read_attr_scalar<std::int64_t>(g, "slots", H5T_NATIVE_INT64, path, where);
  c.time = read_attr_scalar<double>(g, "time", H5T_NATIVE_DOUBLE, path, where);
  c.dt = read_attr_scalar<double>(g, "dt", H5T_NATIVE_DOUBLE, path, where);
  c.steps = read_attr_scalar<std::int64_t>(g, "steps", H5T_NATIVE_INT64, path, where);
  c.dissipated = read_attr_scalar<double>(g, "dissipated", H5T_NATIVE_DOUBLE, path, where);
  c.last_rate = read_attr_scalar<double>(g, "last_dissipation_rate", H5T_NATIVE_DOUBLE, path, where);
  c.validity_energy0 = read_attr_scalar<double>(g, "validity_energy0", H5T_NATIVE_DOUBLE, path, where);
  c.validity_scale = read_attr_scalar<double>(g, "validity_scale", H5T_NATIVE_DOUBLE, path, where);
  c.frames_written = read_attr_scalar<std::int64_t>(g, "frames_written", H5T_NATIVE_INT64, path, where);
  const Id sg = checked(H5Gopen2(f, "scene", H5P_DEFAULT), H5Gclose, path, "missing group /scene");
  c.scene_text = read_attr_string(sg.get(), "text", path, "/scene.");
  c.scene_source = read_attr_string(sg.get(), "source", path, "/scene.");
  if (c.slots <= 0 || !(c.dt > 0))
    fail(path, "/checkpoint has slots = " + std::to_string(c.slots) + ", dt = " + std::to_string(c.dt));
}

// /checkpoint's state arrays ([rows, slots] in the checkpoint's precision)
// and its contact work.
void read_checkpoint_state(hid_t g, const std::string& path, Checkpoint& c) {
  const std::string prec = c.float32 ? "float" : "double";
  const hid_t type = c.float32 ? H5T_NATIVE_FLOAT : H5T_NATIVE_DOUBLE;
  const std::size_t es = c.float32 ? 4 : 8;
  auto get = [&](const char* name, std::vector<unsigned char>& bytes, hsize_t rows) {
    const Id d = open_dataset(g, name, path);
    const auto dims = dataset_dims(d.get());
    if (dims != std::vector<hsize_t>{rows, hsize_t(c.slots)})
      fail(path, std::string("/checkpoint/") + name + " has shape " + dims_str(dims) + ", expected " +
                     dims_str({rows, hsize_t(c.slots)}));
    const Id ft(H5Dget_type(d.get()), H5Tclose);
    if (H5Tget_class(ft.get()) != H5T_FLOAT || H5Tget_size(ft.get()) != es)
      fail(path, std::string("/checkpoint/") + name + " is not " + prec + " data");
    plausible(path, std::string("/checkpoint/") + name, double(rows) * double(c.slots), double(es));
    bytes.resize(rows * std::size_t(c.slots) * es);
    check(H5Dread(d.get(), type, H5S_ALL, H5S_ALL, H5P_DEFAULT, bytes.data()), path,
          std::string("cannot read /checkpoint/") + name + " (truncated or damaged file?)");
  };
  // float-only arrays are optional (a file from before they existed)
#define MANYRODS_GET(name, n, fill, float_only, doc) \
  if (!(float_only) || H5Lexists(g, #name, H5P_DEFAULT) > 0) get(#name, c.name, n);
  MANYRODS_STATE_FIELDS(MANYRODS_GET)
#undef MANYRODS_GET
  if (H5Lexists(g, "contact_work", H5P_DEFAULT) > 0) get("contact_work", c.contact_work, 1);
  if (H5Lexists(g, "contact_impulses", H5P_DEFAULT) > 0) {  // (files from before it: none)
    const Id d = open_dataset(g, "contact_impulses", path);
    const auto dims = dataset_dims(d.get());
    constexpr hsize_t cols = Checkpoint::kContactImpulseColumns;
    if (dims.size() != 2 || dims[1] != cols)
      fail(path, "/checkpoint/contact_impulses has shape " + dims_str(dims) + ", expected [rows, " +
                     std::to_string(cols) + "]");
    const Id ft(H5Dget_type(d.get()), H5Tclose);
    if (H5Tget_class(ft.get()) != H5T_FLOAT || H5Tget_size(ft.get()) != 8)
      fail(path, "/checkpoint/contact_impulses is not double data");
    plausible(path, "/checkpoint/contact_impulses", double(dims[0]) * double(cols), 8);
    c.contact_impulses.resize(std::size_t(dims[0] * cols));
    check(H5Dread(d.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, c.contact_impulses.data()), path,
          "cannot read /checkpoint/contact_impulses (truncated or damaged file?)");
  }
}

// /checkpoint/probes (there when the run has probes): each probe's records
// so far.
void read_checkpoint_probes(hid_t g, const std::string& path, Checkpoint& c) {
  const Id pg = checked(H5Gopen2(g, "probes", H5P_DEFAULT), H5Gclose, path, "cannot open /checkpoint/probes");
  auto get_d = [&](const char* name, std::vector<double>& v, std::size_t rank) {
    const Id d = open_dataset(pg.get(), name, path);
    const auto dims = dataset_dims(d.get());
    if (dims.size() != rank) fail(path, std::string("/checkpoint/probes/") + name + " has shape " + dims_str(dims));
    double count = 1;
    for (hsize_t x : dims) count *= double(x);
    plausible(path, std::string("/checkpoint/probes/") + name, count, 8);
    const std::size_t n = std::size_t(count);
    v.resize(n);
    if (n > 0)
      check(H5Dread(d.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()), path,
            std::string("cannot read /checkpoint/probes/") + name + " (truncated or damaged file?)");
    return dims;
  };
  const auto dt_dims = get_d("time", c.probe_time, 2);
  c.probe_count = std::int64_t(dt_dims[0]);
  c.probe_samples = std::int64_t(dt_dims[1]);
  if (c.probe_count < 1 || c.probe_samples < 1)
    fail(path, "/checkpoint/probes/time has shape " + dims_str(dt_dims) + ": no records");
  const auto tip_dims = get_d("tip", c.probe_tip, 3);
  if (tip_dims != std::vector<hsize_t>{dt_dims[0], dt_dims[1], 3})
    fail(path, "/checkpoint/probes/tip has shape " + dims_str(tip_dims) + ", expected " +
                   dims_str({dt_dims[0], dt_dims[1], 3}));
  for (auto [name, v] : {std::pair{"max_strain", &c.probe_max_strain}, std::pair{"dissipated", &c.probe_dissipated},
                         std::pair{"dissipation_rate", &c.probe_rate}}) {
    const auto d = get_d(name, *v, 1);
    if (d[0] != dt_dims[0])
      fail(path, std::string("/checkpoint/probes/") + name + " has " + std::to_string(d[0]) + " entries, " +
                     std::to_string(dt_dims[0]) + " probes expected");
  }
  if (H5Lexists(pg.get(), "failed_at", H5P_DEFAULT) > 0 && get_d("failed_at", c.probe_failed_at, 1)[0] != dt_dims[0])
    fail(path, "/checkpoint/probes/failed_at has " + std::to_string(c.probe_failed_at.size()) + " entries, " +
                   std::to_string(dt_dims[0]) + " probes expected");
  for (auto [name, v] :
       {std::pair{"observed", &c.probe_observed}, std::pair{"observed_last", &c.probe_observed_last}}) {
    if (H5Lexists(pg.get(), name, H5P_DEFAULT) <= 0) continue;
    const auto d = get_d(name, *v, 2);
    if (d[0] != dt_dims[0])
      fail(path, std::string("/checkpoint/probes/") + name + " has " + std::to_string(d[0]) + " rows, " +
                     std::to_string(dt_dims[0]) + " probes expected");
  }
}

// /sweep (there when the run is a sweep's): its variations' first rods,
// sensitivity base and parameters.
void read_checkpoint_sweep(hid_t f, const std::string& path, Checkpoint& c) {
  const Id sg = checked(H5Gopen2(f, "sweep", H5P_DEFAULT), H5Gclose, path, "cannot open /sweep");
  c.sweep_first_rod = read_vector<std::int32_t>(sg.get(), "variation_first_rod", H5T_NATIVE_INT32, path);
  if (H5Aexists(sg.get(), "sensitivity_base") > 0) {
    const std::int64_t base =
        read_attr_scalar<std::int64_t>(sg.get(), "sensitivity_base", H5T_NATIVE_INT64, path, "/sweep.");
    const std::int64_t n = std::int64_t(c.sweep_first_rod.size());
    if (base < 1 || n % base != 0)
      fail(path, "/sweep.sensitivity_base = " + std::to_string(base) + " does not divide the " + std::to_string(n) +
                     " variations");
    c.sweep_sensitivity_base = int(base);
  }
  const Id pg = checked(H5Gopen2(sg.get(), "parameters", H5P_DEFAULT), H5Gclose, path,
                        "missing group /sweep/parameters");
  std::stringstream ss(read_attr_string(pg.get(), "order", path, "/sweep/parameters."));
  for (std::string n; std::getline(ss, n);) {
    c.sweep_parameters.push_back({n, read_vector<double>(pg.get(), n.c_str(), H5T_NATIVE_DOUBLE, path)});
    if (c.sweep_parameters.back().values.size() != c.sweep_first_rod.size())
      fail(path, "/sweep/parameters/" + n + " has " + std::to_string(c.sweep_parameters.back().values.size()) +
                     " values, " + std::to_string(c.sweep_first_rod.size()) + " variations expected");
  }
}
}  // namespace

Checkpoint read_checkpoint(const std::string& path) {
  const Id f = open_manyrods(path);
  if (H5Lexists(f.get(), "checkpoint", H5P_DEFAULT) <= 0)
    fail(path, "no /checkpoint group (not a finished or interrupted manyrods run)");
  const Id g =
      checked(H5Gopen2(f.get(), "checkpoint", H5P_DEFAULT), H5Gclose, path, "cannot open /checkpoint");
  Checkpoint c;
  read_checkpoint_run(f.get(), g.get(), path, c);
  read_checkpoint_state(g.get(), path, c);
  if (H5Lexists(g.get(), "probes", H5P_DEFAULT) > 0) read_checkpoint_probes(g.get(), path, c);
  c.from_sweep = H5Lexists(f.get(), "sweep", H5P_DEFAULT) > 0;
  if (c.from_sweep) read_checkpoint_sweep(f.get(), path, c);
  return c;
}

struct Reader::Impl {
  std::string path;
  Id file, pos, dir;
  Output out;
  std::int64_t frames = 0;
};

Reader::Reader(const std::string& path) : impl_(new Impl) {
  Impl& r = *impl_;
  r.path = path;
  r.file = open_manyrods(path);
  const hid_t f = r.file.get();
  Output& o = r.out;
  o.dt = read_attr_scalar<double>(f, "dt", H5T_NATIVE_DOUBLE, path, "/");
  o.time = read_vector<double>(f, "time", H5T_NATIVE_DOUBLE, path);
  o.node_offsets = read_vector<std::int64_t>(f, "node_offsets", H5T_NATIVE_INT64, path);
  o.element_offsets = read_vector<std::int64_t>(f, "element_offsets", H5T_NATIVE_INT64, path);
  if (o.node_offsets.size() < 2) fail(path, "/node_offsets has fewer than 2 entries");
  if (o.element_offsets.size() != o.node_offsets.size())
    fail(path, "/element_offsets and /node_offsets do not have one entry per rod + 1");
  for (std::size_t i = 1; i < o.node_offsets.size(); ++i)
    if (o.node_offsets[i] <= o.node_offsets[i - 1] || o.element_offsets[i] < o.element_offsets[i - 1] ||
        o.node_offsets[i] - o.node_offsets[i - 1] != o.element_offsets[i] - o.element_offsets[i - 1] + 1)
      fail(path, "/node_offsets and /element_offsets do not describe rods (entry " + std::to_string(i) + ")");
  if (o.node_offsets[0] != 0 || o.element_offsets[0] != 0) fail(path, "/node_offsets or /element_offsets do not start at 0");
  o.nodes = o.node_offsets.back();
  o.rod_group = read_vector<std::int32_t>(f, "rods/group", H5T_NATIVE_INT32, path);
  o.rod_width = read_vector<double>(f, "rods/width", H5T_NATIVE_DOUBLE, path);
  if (std::int64_t(o.rod_group.size()) + 1 != std::int64_t(o.node_offsets.size()) ||
      o.rod_width.size() != o.rod_group.size())
    fail(path, "/rods/group and /rods/width do not have one entry per rod");
  if (H5Lexists(f, "rods/node_width", H5P_DEFAULT) > 0) {
    o.node_width = read_vector<double>(f, "rods/node_width", H5T_NATIVE_DOUBLE, path);
    if (std::int64_t(o.node_width.size()) != o.nodes) fail(path, "/rods/node_width does not have one entry per node");
  }
  {
    const Id g = checked(H5Gopen2(f, "rods", H5P_DEFAULT), H5Gclose, path, "cannot open /rods");
    std::stringstream ss(read_attr_string(g.get(), "group_names", path, "/rods."));
    for (std::string n; std::getline(ss, n);) o.group_names.push_back(n);
  }
  r.frames = std::int64_t(o.time.size());
  {
    const Id sg = checked(H5Gopen2(f, "scene", H5P_DEFAULT), H5Gclose, path, "missing group /scene");
    o.scene_text = read_attr_string(sg.get(), "text", path, "/scene.");
    o.scene_source = read_attr_string(sg.get(), "source", path, "/scene.");
  }
  o.energy.resize(std::size_t(r.frames));
  const bool contact = o.contact = H5Lexists(f, "contact", H5P_DEFAULT) > 0;
  for (const EnergyDataset& d : kEnergyDatasets) {
    if (d.contact_only && !contact) continue;
    const std::string name = std::string("energy/") + d.name;
    const std::vector<double> v = read_vector<double>(f, name.c_str(), H5T_NATIVE_DOUBLE, path);
    if (std::int64_t(v.size()) != r.frames)
      fail(path, "/" + name + " has " + std::to_string(v.size()) + " entries, /time " + std::to_string(r.frames));
    for (std::int64_t k = 0; k < r.frames; ++k) o.energy[std::size_t(k)].*d.member = v[std::size_t(k)];
  }
  if (contact) {
    const std::vector<double> n = read_vector<double>(f, "contact/count", H5T_NATIVE_DOUBLE, path);
    const std::vector<double> d = read_vector<double>(f, "contact/max_penetration", H5T_NATIVE_DOUBLE, path);
    if (std::int64_t(n.size()) != r.frames || std::int64_t(d.size()) != r.frames)
      fail(path, "/contact/count and /contact/max_penetration must have one entry per frame (" +
                     std::to_string(r.frames) + ")");
    for (std::int64_t k = 0; k < r.frames; ++k) {
      o.energy[std::size_t(k)].contacts = n[std::size_t(k)];
      o.energy[std::size_t(k)].max_penetration = d[std::size_t(k)];
    }
  }
  r.pos = open_dataset(f, fields::public_name::node_x, path);
  const auto dims = dataset_dims(r.pos.get());
  const std::vector<hsize_t> want{hsize_t(r.frames), hsize_t(o.nodes), 3};
  if (dims != want) fail(path, "/node_position has shape " + dims_str(dims) + ", expected " + dims_str(want));
  if (H5Lexists(f, "observables", H5P_DEFAULT) > 0) o.observables = read_column_group(f, "observables", path);
  // a calibration's tables, each with its rows' (or tracks') names
  struct Table {
    const char* name;
    std::vector<Column>* cols;
    const char* attr;
    std::vector<std::string>* names;
  };
  for (const auto& [name, cols, attr, names] :
       {Table{"calibration", &o.calibration, "rows", &o.calibration_rows},
        Table{"calibration_history", &o.calibration_history, "", nullptr},
        Table{"calibration_tracks", &o.calibration_tracks, "tracks", &o.calibration_track_names},
        Table{"calibration_scalars", &o.calibration_scalars, "rows", &o.calibration_scalar_names}}) {
    if (H5Lexists(f, name, H5P_DEFAULT) <= 0) continue;
    *cols = read_column_group(f, name, path);
    if (!names) continue;
    const Id g = checked(H5Gopen2(f, name, H5P_DEFAULT), H5Gclose, path, std::string("missing group /") + name);
    std::stringstream ss(read_attr_string(g.get(), attr, path, std::string("/") + name + "."));
    for (std::string n; std::getline(ss, n);) names->push_back(n);
  }
  if (H5Lexists(f, "sweep", H5P_DEFAULT) > 0) {
    o.has_sweep = true;
    auto cols = [&](const char* name, std::vector<Column>& out) { out = read_column_group(f, std::string("sweep/") + name, path); };
    cols("parameters", o.sweep_parameters);
    cols("summary", o.sweep_summary);
    {
      const Id g = checked(H5Gopen2(f, "sweep", H5P_DEFAULT), H5Gclose, path, "missing group /sweep");
      o.sweep_first_rod = read_vector<std::int32_t>(g.get(), "variation_first_rod", H5T_NATIVE_INT32, path);
    }
    if (H5Lexists(f, "sweep/statistics", H5P_DEFAULT) > 0) {
      cols("statistics", o.sweep_statistics);
      const Id g = checked(H5Gopen2(f, "sweep/statistics", H5P_DEFAULT), H5Gclose, path, "missing /sweep/statistics");
      std::stringstream ss(read_attr_string(g.get(), "statistics", path, "/sweep/statistics."));
      for (std::string n; std::getline(ss, n);) o.sweep_statistic_names.push_back(n);
      for (const Column& c : o.sweep_statistics)
        if (c.values.size() != o.sweep_statistic_names.size())
          fail(path, "/sweep/statistics/" + c.name + " has " + std::to_string(c.values.size()) +
                         " values for " + std::to_string(o.sweep_statistic_names.size()) + " statistics");
    }
  }
}

Reader::~Reader() = default;
const Output& Reader::output() const { return impl_->out; }
std::int64_t Reader::frames() const { return impl_->frames; }

bool Reader::has_directors() const {
  return H5Lexists(impl_->file.get(), fields::public_name::elem_Q, H5P_DEFAULT) > 0;
}

void Reader::read_directors(std::int64_t f, std::vector<double>& out) const {
  Impl& r = *impl_;
  if (f < 0 || f >= r.frames) fail(r.path, "frame " + std::to_string(f) + " out of range");
  if (!r.dir.ok())
    r.dir = checked(H5Dopen2(r.file.get(), fields::public_name::elem_Q, H5P_DEFAULT), H5Dclose, r.path,
                    "no /element_directors (written with output_directors = false?)");
  const std::int64_t elements = r.out.element_offsets.back();
  plausible(r.path, "/element_directors", double(elements) * 9, 8);
  out.resize(std::size_t(elements) * 9);
  const Id fs = checked(H5Dget_space(r.dir.get()), H5Sclose, r.path, "cannot read the shape of /element_directors");
  hsize_t dims[4] = {0, 0, 0, 0};
  if (H5Sget_simple_extent_ndims(fs.get()) != 4 || H5Sget_simple_extent_dims(fs.get(), dims, nullptr) != 4 ||
      dims[0] < hsize_t(r.frames) || dims[1] != hsize_t(elements) || dims[2] != 3 || dims[3] != 3)
    fail(r.path, "/element_directors does not have the shape [frames, elements, 3, 3]");
  const hsize_t start[4] = {hsize_t(f), 0, 0, 0}, count[4] = {1, hsize_t(elements), 3, 3};
  check(H5Sselect_hyperslab(fs.get(), H5S_SELECT_SET, start, nullptr, count, nullptr), r.path,
        "bad frame selection");
  const Id ms(H5Screate_simple(4, count, nullptr), H5Sclose);
  check(H5Dread(r.dir.get(), H5T_NATIVE_DOUBLE, ms.get(), fs.get(), H5P_DEFAULT, out.data()), r.path,
        "cannot read /element_directors frame " + std::to_string(f) + " (truncated or damaged file?)");
}

void Reader::read_positions(std::int64_t f, std::vector<double>& out) const {
  const Impl& r = *impl_;
  if (f < 0 || f >= r.frames) fail(r.path, "frame " + std::to_string(f) + " out of range");
  plausible(r.path, "/node_position", double(r.out.nodes) * 3, 8);
  out.resize(std::size_t(r.out.nodes) * 3);
  const Id fs(H5Dget_space(r.pos.get()), H5Sclose);
  const hsize_t start[3] = {hsize_t(f), 0, 0}, count[3] = {1, hsize_t(r.out.nodes), 3};
  check(H5Sselect_hyperslab(fs.get(), H5S_SELECT_SET, start, nullptr, count, nullptr), r.path,
        "bad frame selection");
  const Id ms(H5Screate_simple(3, count, nullptr), H5Sclose);
  check(H5Dread(r.pos.get(), H5T_NATIVE_DOUBLE, ms.get(), fs.get(), H5P_DEFAULT, out.data()), r.path,
        "cannot read /node_position frame " + std::to_string(f) + " (truncated or damaged file?)");
}

}  // namespace manyrods::h5
