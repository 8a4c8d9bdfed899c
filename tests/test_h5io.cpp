// tests/test_h5io.cpp — the HDF5 output file (include/manyrods/h5io.h): round trip of
// frames, energies and checkpoints in double and float; the temporary file
// and the rename; h5py reads the layout docs/scenes.md documents; missing,
// foreign, truncated and incomplete files give clear errors.
#include <gtest/gtest.h>
#include <hdf5.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <typeinfo>
#include <vector>

#include "manyrods/h5io.h"

using namespace manyrods;
namespace fs = std::filesystem;

namespace {

fs::path temp_dir() {
  const fs::path d = fs::temp_directory_path() / ("manyrods_test_h5io_" + std::to_string(::getpid()));
  fs::create_directories(d);
  return d;
}

// Two rods of 3 and 2 elements.
h5::Layout layout(bool float32) {
  h5::Layout l;
  l.node_offsets = {0, 4, 7};
  l.element_offsets = {0, 3, 5};
  l.rod_group = {0, 1};
  l.rod_width = {0.01, 0.002};
  l.group_names = {"beam", "hair"};
  l.float32 = float32;
  return l;
}

h5::RunInfo info() { return {"[simulation]\ndt = 1e-3\n# ünïcode\n", "scene.toml", "pefrl", 1e-3}; }

template <class T>
std::vector<T> random_values(std::size_t n, unsigned seed) {
  std::mt19937 g(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<T> v(n);
  for (auto& x : v) x = T(u(g));
  return v;
}

template <class T>
std::vector<unsigned char> bytes_of(const std::vector<T>& v) {
  std::vector<unsigned char> b(v.size() * sizeof(T));
  std::memcpy(b.data(), v.data(), b.size());
  return b;
}

template <class T>
h5::Checkpoint checkpoint(std::int64_t slots) {
  h5::Checkpoint c;
  c.float32 = std::is_same_v<T, float>;
  c.slots = slots;
  c.time = 0.123456789;
  c.dt = 1e-3;
  c.steps = 123;
  c.dissipated = 4.5e-3;
  c.last_rate = 6.7e-4;
  c.frames_written = 3;
  c.scene_text = info().scene_text;
  c.scene_source = "scene.toml";
  c.node_x = bytes_of(random_values<T>(3 * slots, 1));
  c.node_v = bytes_of(random_values<T>(3 * slots, 2));
  c.elem_Q = bytes_of(random_values<T>(9 * slots, 3));
  c.elem_w = bytes_of(random_values<T>(3 * slots, 4));
  // a sweep's records: 2 probes × 5 samples
  c.probe_count = 2;
  c.probe_samples = 5;
  c.probe_time = random_values<double>(10, 5);
  c.probe_tip = random_values<double>(30, 6);
  c.probe_max_strain = {0.01, 0.02};
  c.probe_dissipated = {1e-3, 2e-3};
  c.probe_rate = {3e-4, 4e-4};
  return c;
}

// Writes 3 frames and a checkpoint; returns the positions written.
template <class T>
std::vector<std::vector<T>> write_file(const std::string& path) {
  h5::Writer w(path, layout(std::is_same_v<T, float>), info());
  std::vector<std::vector<T>> frames;
  for (int f = 0; f < 3; ++f) {
    frames.push_back(random_values<T>(7 * 3, 10 + f));
    const std::vector<T> dir = random_values<T>(5 * 9, 20 + f);
    h5::EnergyRow e;
    e.kinetic = 1.0 + f;
    e.elastic = 2.0;
    e.potential = 3.0;
    e.dissipation = 0.25;
    e.dissipated = 0.5 * f;
    w.append_frame(0.1 * f, frames.back().data(), dir.data(), e);
  }
  w.write_checkpoint(checkpoint<T>(64));
  w.finish();
  return frames;
}

template <class F>
void expect_h5_error(F&& f, const std::vector<std::string>& needles) {
  try {
    f();
    ADD_FAILURE() << "no H5Error";
  } catch (const h5::H5Error& e) {
    const std::string msg = e.what();
    for (const std::string& n : needles)
      EXPECT_NE(msg.find(n), std::string::npos) << "'" << n << "' not in: " << msg;
  }
}

bool python_h5py() { return std::system("/usr/bin/python3 -c 'import h5py, numpy' > /dev/null 2>&1") == 0; }

}  // namespace

template <class T>
void round_trip() {
  const std::string path = (temp_dir() / (std::string("rt_") + typeid(T).name() + ".h5")).string();
  const auto frames = write_file<T>(path);
  const h5::Reader r(path);
  const h5::Output& o = r.output();
  ASSERT_EQ(r.frames(), 3);
  EXPECT_EQ(o.time, (std::vector<double>{0.0, 0.1, 0.2}));
  EXPECT_EQ(o.node_offsets, (std::vector<std::int64_t>{0, 4, 7}));
  EXPECT_EQ(o.element_offsets, (std::vector<std::int64_t>{0, 3, 5}));
  EXPECT_EQ(o.rod_group, (std::vector<std::int32_t>{0, 1}));
  EXPECT_EQ(o.rod_width, (std::vector<double>{0.01, 0.002}));
  EXPECT_EQ(o.group_names, (std::vector<std::string>{"beam", "hair"}));
  EXPECT_EQ(o.scene_text, info().scene_text);
  EXPECT_EQ(o.dt, 1e-3);
  for (int f = 0; f < 3; ++f) {
    EXPECT_EQ(o.energy[f].kinetic, 1.0 + f);
    EXPECT_EQ(o.energy[f].elastic, 2.0);
    EXPECT_EQ(o.energy[f].potential, 3.0);
    EXPECT_EQ(o.energy[f].dissipation, 0.25);
    EXPECT_EQ(o.energy[f].dissipated, 0.5 * f);
    std::vector<double> p;
    r.read_positions(f, p);
    ASSERT_EQ(p.size(), 21u);
    for (int i = 0; i < 21; ++i) EXPECT_EQ(p[i], double(frames[f][i]));  // exact: T → double
  }
  const h5::Checkpoint c = h5::read_checkpoint(path), ref = checkpoint<T>(64);
  EXPECT_EQ(c.float32, ref.float32);
  EXPECT_EQ(c.slots, 64);
  EXPECT_EQ(c.time, ref.time);
  EXPECT_EQ(c.dt, ref.dt);
  EXPECT_EQ(c.steps, ref.steps);
  EXPECT_EQ(c.dissipated, ref.dissipated);
  EXPECT_EQ(c.last_rate, ref.last_rate);
  EXPECT_EQ(c.frames_written, 3);
  EXPECT_EQ(c.scene_text, ref.scene_text);
  EXPECT_EQ(c.node_x, ref.node_x);  // bit-identical raw slot arrays
  EXPECT_EQ(c.node_v, ref.node_v);
  EXPECT_EQ(c.elem_Q, ref.elem_Q);
  EXPECT_EQ(c.elem_w, ref.elem_w);
  EXPECT_EQ(c.probe_count, 2);
  EXPECT_EQ(c.probe_samples, 5);
  EXPECT_EQ(c.probe_time, ref.probe_time);
  EXPECT_EQ(c.probe_tip, ref.probe_tip);
  EXPECT_EQ(c.probe_max_strain, ref.probe_max_strain);
  EXPECT_EQ(c.probe_dissipated, ref.probe_dissipated);
  EXPECT_EQ(c.probe_rate, ref.probe_rate);
  EXPECT_FALSE(c.from_sweep);
}

TEST(H5io, RoundTripDouble) { round_trip<double>(); }
TEST(H5io, RoundTripFloat) { round_trip<float>(); }

TEST(H5io, WritesATemporaryFileAndRenamesItAtTheEnd) {
  const fs::path d = temp_dir();
  const std::string path = (d / "keep.h5").string();
  { std::ofstream(path) << "previous result"; }
  {
    h5::Writer w(path, layout(false), info());
    const std::vector<double> p(21, 1.0), q(45, 0.0);
    w.append_frame(0, p.data(), q.data(), {});
    EXPECT_TRUE(fs::exists(path + ".tmp"));
    std::ifstream in(path);
    std::string s;
    std::getline(in, s);
    EXPECT_EQ(s, "previous result");  // untouched while the run writes
  }  // abandoned without finish(): the temporary file goes, the old output stays
  EXPECT_FALSE(fs::exists(path + ".tmp"));
  {
    std::ifstream in(path);
    std::string s;
    std::getline(in, s);
    EXPECT_EQ(s, "previous result");
  }
  write_file<double>(path);
  EXPECT_FALSE(fs::exists(path + ".tmp"));
  EXPECT_EQ(h5::Reader(path).frames(), 3);
}

TEST(H5io, BadFilesGiveClearErrors) {
  const fs::path d = temp_dir();
  const std::string missing = (d / "missing.h5").string();
  expect_h5_error([&] { h5::Reader r(missing); }, {missing, "no such file"});
  expect_h5_error([&] { (void)h5::read_checkpoint(missing); }, {missing, "no such file"});

  const std::string text = (d / "text.h5").string();
  std::ofstream(text) << "this is not HDF5\n";
  expect_h5_error([&] { h5::Reader r(text); }, {text, "not an HDF5 file"});

  // truncated: a valid output cut in half
  const std::string good = (d / "good.h5").string(), cut = (d / "cut.h5").string();
  write_file<double>(good);
  fs::copy_file(good, cut, fs::copy_options::overwrite_existing);
  fs::resize_file(cut, fs::file_size(good) / 2);
  expect_h5_error([&] { h5::Reader r(cut); }, {cut, "truncated or damaged"});
  expect_h5_error([&] { (void)h5::read_checkpoint(cut); }, {cut, "truncated or damaged"});

  // foreign: an HDF5 file from someone else
  const std::string foreign = (d / "foreign.h5").string();
  {
    const hid_t f = H5Fcreate(foreign.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    const hsize_t n = 4;
    const hid_t sp = H5Screate_simple(1, &n, nullptr);
    const hid_t ds = H5Dcreate2(f, "time", H5T_NATIVE_DOUBLE, sp, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    const double v[4] = {0, 1, 2, 3};
    H5Dwrite(ds, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v);
    H5Dclose(ds);
    H5Sclose(sp);
    H5Fclose(f);
  }
  expect_h5_error([&] { h5::Reader r(foreign); }, {foreign, "not a manyrods output"});
  expect_h5_error([&] { (void)h5::read_checkpoint(foreign); }, {foreign, "not a manyrods output"});

  // a variable-length string attribute is never read (libhdf5 reads it from
  // the global heap, where damage crashes it): a version-1 file is refused by
  // its version, a forged one by the string's type
  auto vlen_file = [](const std::string& path, std::int64_t version) {
    const hid_t f = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    const hid_t sp = H5Screate(H5S_SCALAR);
    const hid_t t = H5Tcopy(H5T_C_S1);
    H5Tset_size(t, H5T_VARIABLE);
    const char* v = "manyrods";
    const hid_t a = H5Acreate2(f, "format", t, sp, H5P_DEFAULT, H5P_DEFAULT);
    H5Awrite(a, t, &v);
    const hid_t b = H5Acreate2(f, "format_version", H5T_NATIVE_INT64, sp, H5P_DEFAULT, H5P_DEFAULT);
    H5Awrite(b, H5T_NATIVE_INT64, &version);
    H5Aclose(a);
    H5Aclose(b);
    H5Tclose(t);
    H5Sclose(sp);
    H5Fclose(f);
  };
  const std::string v1 = (d / "v1.h5").string(), forged = (d / "forged.h5").string();
  vlen_file(v1, 1);
  vlen_file(forged, 2);
  expect_h5_error([&] { (void)h5::read_checkpoint(v1); }, {v1, "format_version 1, this manyrods reads 2"});
  expect_h5_error([&] { h5::Reader r(forged); }, {forged, "attribute /format is a variable-length string"});

  // a damaged byte in the checkpoint's data: its chunk's checksum fails
  const std::string flipped = (d / "flipped.h5").string();
  {
    write_file<double>(flipped);
    const hid_t f = H5Fopen(flipped.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    const hid_t ds = H5Dopen2(f, "checkpoint/node_x", H5P_DEFAULT);
    haddr_t offset = HADDR_UNDEF;
    hsize_t size = 0;
    const hsize_t start[2] = {0, 0};
    H5Dget_chunk_info_by_coord(ds, start, nullptr, &offset, &size);
    H5Dclose(ds);
    H5Fclose(f);
    ASSERT_NE(offset, HADDR_UNDEF);
    std::fstream io(flipped, std::ios::in | std::ios::out | std::ios::binary);
    io.seekg(std::streamoff(offset + size / 2));
    char c = 0;
    io.get(c);
    io.seekp(std::streamoff(offset + size / 2));
    io.put(char(c ^ 0x5a));
  }
  expect_h5_error([&] { (void)h5::read_checkpoint(flipped); }, {flipped, "checkpoint"});

  // a manyrods output without a checkpoint (e.g. written by an older tool)
  const std::string nock = (d / "nocheckpoint.h5").string();
  {
    h5::Writer w(nock, layout(false), info());
    const std::vector<double> p(21, 1.0), q(45, 0.0);
    w.append_frame(0, p.data(), q.data(), {});
    w.finish();
  }
  EXPECT_EQ(h5::Reader(nock).frames(), 1);
  expect_h5_error([&] { (void)h5::read_checkpoint(nock); }, {nock, "no /checkpoint group"});

  // a directory that does not exist
  expect_h5_error([&] { h5::Writer w((d / "no" / "such" / "dir.h5").string(), layout(false), info()); },
                  {"cannot create the output file"});
}

TEST(H5io, H5pyReadsTheDocumentedLayout) {
  if (!python_h5py())
    GTEST_SKIP() << "/usr/bin/python3 with h5py and numpy not installed (apt-get install python3-h5py)";
  const std::string path = (temp_dir() / "py.h5").string();
  const auto frames = write_file<float>(path);
  const std::string script = (temp_dir() / "check.py").string();
  {
    std::ofstream py(script);
    py.precision(9);
    py << "import sys, h5py, numpy as np\n"
          "f = h5py.File(sys.argv[1], 'r')\n"
          "s = lambda a: a.decode('utf-8')  # fixed-length string attributes: bytes in h5py\n"
          "assert s(f.attrs['format']) == 'manyrods', f.attrs['format']\n"
          "assert f.attrs['format_version'] == 2\n"
          "assert s(f.attrs['precision']) == 'float'\n"
          "assert f['time'].shape == (3,)\n"
          "assert f['node_offsets'][:].tolist() == [0, 4, 7]\n"
          "p = f['node_position']\n"
          "assert p.shape == (3, 7, 3) and p.dtype == np.float32, (p.shape, p.dtype)\n"
          "assert p.compression == 'gzip' and p.chunks is not None\n"
          "assert f['element_directors'].shape == (3, 5, 3, 3)\n"
          "assert f['energy/kinetic'][:].tolist() == [1.0, 2.0, 3.0]\n"
          "assert 'ünïcode' in s(f['scene'].attrs['text'])\n"
          "assert p.fletcher32 and f['checkpoint/node_x'].fletcher32  # checksummed chunks\n"
          "assert f['checkpoint/node_x'].shape == (3, 64)\n"
          "assert f['checkpoint'].attrs['steps'] == 123\n"
          "rod1 = p[2, f['node_offsets'][1]:f['node_offsets'][2]]\n"
          "print(' '.join(repr(float(x)) for x in rod1.ravel()))\n";
  }
  const std::string out = (temp_dir() / "py.out").string();
  ASSERT_EQ(std::system(("/usr/bin/python3 " + script + " " + path + " > " + out + " 2>&1").c_str()), 0)
      << std::ifstream(out).rdbuf();
  std::ifstream in(out);
  for (int i = 12; i < 21; ++i) {  // rod 1 = nodes 4..6 of frame 2
    double v;
    ASSERT_TRUE(in >> v);
    EXPECT_EQ(v, double(frames[2][i]));
  }
}

// Removes this test's temporary directory after all tests ran.
class CleanUp : public ::testing::Environment {
 public:
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(temp_dir(), ec);
  }
};
const auto* const kCleanUp = ::testing::AddGlobalTestEnvironment(new CleanUp);
