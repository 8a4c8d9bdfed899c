/* tests/test_c_api.c — the C API (include/manyrods/manyrods_c.h) from a C11
 * program, as a host application uses it: versions, errors (status, message,
 * thread-local), a scene's batch stepped bit for bit as `manyrods run`,
 * rods described in C, zero-copy state views, loads, host-driven roots,
 * tips and colliders.
 *
 *   test_c_api WORK_DIR [MANYRODS_CLI]
 * WORK_DIR: where the test writes its scene files; with the command-line tool
 * the scene's state hash is compared with the tool's run. Exits 1 at the
 * first failed check, naming it. */
#define _POSIX_C_SOURCE 200809L

#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "manyrods/manyrods_c.h"

static int checks = 0;

#define CHECK(cond, ...)                                                   \
  do {                                                                     \
    ++checks;                                                              \
    if (!(cond)) {                                                         \
      fprintf(stderr, "%s:%d: check failed: %s\n  ", __FILE__, __LINE__, #cond); \
      fprintf(stderr, __VA_ARGS__);                                        \
      fprintf(stderr, "\n  mr_last_error: %s\n", mr_last_error());       \
      exit(1);                                                             \
    }                                                                      \
  } while (0)

#define OK(call) CHECK((call) == MR_OK, "%s", #call)

static char work[4096];

static const char* write_file(const char* name, const char* text) {
  static char path[4200];
  snprintf(path, sizeof path, "%s/%s", work, name);
  FILE* f = fopen(path, "w");
  CHECK(f != NULL, "cannot write %s", path);
  fputs(text, f);
  fclose(f);
  return path;
}

/* A rod hanging from a hand, a ball that the host moves into it. Both
 * motions are the host's (motion = "host"). */
static const char* kHangScene =
    "[simulation]\n"
    "dt = 1e-4\n"
    "duration = 0.05\n"
    "output_interval = 0.01\n"
    "gravity = [0.0, 0.0, -9.81]\n"
    "[[rods]]\n"
    "name = \"hang\"\n"
    "elements = 20\n"
    "length = 0.5\n"
    "start = [0.0, 0.0, 0.0]\n"
    "direction = [0.0, 0.0, -1.0]\n"
    "section = { shape = \"circle\", radius = 0.005 }\n"
    "material = { density = 1000.0, youngs_modulus = 1e6, poisson_ratio = 0.5 }\n"
    "damping = { tau_shear = 0.01, tau_extension = 0.01 }\n"
    "root = { kind = \"clamped\", motion = \"host\", name = \"hand\" }\n"
    "[[colliders]]\n"
    "name = \"ball\"\n"
    "kind = \"sphere\"\n"
    "center = [-0.2, 0.0, -0.3]\n"
    "radius = 0.05\n"
    "motion = { motion = \"host\", name = \"ball\" }\n";

static void test_versions(void) {
  CHECK(mr_abi_version() == MR_ABI_VERSION, "library ABI %d, header %d", mr_abi_version(), MR_ABI_VERSION);
  CHECK(mr_version() == MR_VERSION, "library %d, header %d", mr_version(), MR_VERSION);
  char v[64];
  snprintf(v, sizeof v, "%d.%d.%d", MR_VERSION_MAJOR, MR_VERSION_MINOR, MR_VERSION_PATCH);
  CHECK(strcmp(mr_version_string(), v) == 0, "version string %s, header %s", mr_version_string(), v);
}

static void test_errors(void) {
  mr_batch* b = (mr_batch*)1;
  char missing[4200];
  snprintf(missing, sizeof missing, "%s/no-such-scene.toml", work);
  CHECK(mr_batch_create_from_scene(missing, &b) == MR_ERROR_IO, "a missing file is an I/O error");
  CHECK(b == NULL, "no handle on failure");
  CHECK(strstr(mr_last_error(), "no-such-scene.toml") != NULL, "the message names the file: %s", mr_last_error());

  const char* bad = write_file("bad.toml", "[simulation]\ndt = 1e-4\nduration = -1.0\n[[rods]]\nelements = 4\n");
  CHECK(mr_batch_create_from_scene(bad, &b) == MR_ERROR_INPUT, "a bad scene is an input error");
  CHECK(strstr(mr_last_error(), "bad.toml:3:") != NULL && strstr(mr_last_error(), "duration") != NULL,
        "the message names the file, line and key: %s", mr_last_error());

  CHECK(mr_batch_create_from_scene(NULL, &b) == MR_ERROR_ARGUMENT, "NULL path");
  CHECK(mr_batch_step(NULL, 1e-4, 1) == MR_ERROR_ARGUMENT, "NULL batch");
  CHECK(mr_batch_node_count(NULL) == 0, "NULL batch: no nodes");
  mr_batch_destroy(NULL);
}

/* mr_last_error is per thread: a thread that has not failed sees "". */
static void* other_thread(void* out) {
  *(int*)out = strcmp(mr_last_error(), "") == 0;
  return NULL;
}
static void test_thread_local_error(void) {
  CHECK(mr_batch_step(NULL, 1e-4, 1) == MR_ERROR_ARGUMENT, "a failing call");
  CHECK(strlen(mr_last_error()) > 0, "this thread has a message");
  int clean = 0;
  pthread_t t;
  CHECK(pthread_create(&t, NULL, other_thread, &clean) == 0, "pthread_create");
  pthread_join(t, NULL);
  CHECK(clean, "another thread's mr_last_error is empty");
}

static uint64_t cli_hash(const char* cli, const char* scene, double duration) {
  char cmd[9000];
  snprintf(cmd, sizeof cmd, "'%s' run '%s' -o '%s/cli.h5' --duration %.17g --no-progress 2>&1", cli, scene, work,
           duration);
  FILE* p = popen(cmd, "r");
  CHECK(p != NULL, "cannot run %s", cmd);
  char line[4096];
  unsigned long long h = 0;
  int found = 0;
  while (fgets(line, sizeof line, p)) {
    const char* s = strstr(line, "state hash ");
    if (s && sscanf(s, "state hash %llx", &h) == 1) found = 1;
  }
  CHECK(pclose(p) == 0 && found, "%s: no state hash", cmd);
  return (uint64_t)h;
}

static void test_scene(const char* cli) {
  const char* path = write_file("hang.toml", kHangScene);
  mr_batch* b = NULL;
  OK(mr_batch_create_from_scene(path, &b));
  CHECK(mr_batch_rod_count(b) == 1 && mr_batch_node_count(b) == 21, "1 rod, 21 nodes (%zu)", mr_batch_node_count(b));
  CHECK(fabs(mr_batch_dt(b) - 1e-4) < 1e-18, "the scene's dt (%g)", mr_batch_dt(b));

  /* the drivers, by name, in order of appearance */
  CHECK(mr_batch_driver_count(b) == 2, "two drivers (%zu)", mr_batch_driver_count(b));
  size_t hand = 9, ball = 9;
  OK(mr_batch_find_driver(b, "hand", &hand));
  OK(mr_batch_find_driver(b, "ball", &ball));
  CHECK(hand == 0 && ball == 1 && strcmp(mr_batch_driver_name(b, 1), "ball") == 0, "driver indices");
  CHECK(mr_batch_driver_name(b, 2) == NULL, "no driver 2");
  size_t none;
  CHECK(mr_batch_find_driver(b, "head", &none) == MR_ERROR_INPUT && strstr(mr_last_error(), "\"hand\"") != NULL,
        "an unknown driver names the known ones: %s", mr_last_error());

  /* without poses set, the batch steps as `manyrods run` does, bit for bit */
  if (cli) {
    mr_batch* r = NULL;
    OK(mr_batch_create_from_scene(path, &r));
    OK(mr_batch_step(r, mr_batch_dt(r), 500));
    const uint64_t h = mr_batch_state_hash(r);
    const uint64_t ref = cli_hash(cli, path, 0.05);
    CHECK(h == ref, "state hash %016llx, manyrods run %016llx", (unsigned long long)h, (unsigned long long)ref);
    mr_batch_destroy(r);
  }

  /* zero copy: the view's pointers stay, its values follow the steps */
  mr_state_view v;
  OK(mr_batch_state_view(b, &v));
  CHECK(v.precision == MR_DOUBLE && v.slots >= 21 && v.component_stride >= v.slots, "the view's layout");
  size_t first_slot;
  int elements;
  OK(mr_batch_rod_slots(b, 0, &first_slot, &elements));
  CHECK(elements == 20, "20 elements");
  const double* x = (const double*)v.node_position;
  const double* z = x + 2 * v.component_stride;
  const size_t tip = first_slot + 20;
  CHECK(fabs(z[tip] + 0.5) < 1e-12 && fabs(x[first_slot]) < 1e-15, "the built rod: tip at z = -0.5 (%g)", z[tip]);

  /* the hand moves the root by 5 cm along x over 0.1 s; the ball comes in
   * from x = -0.2 to x = +0.03 over 0.3 s (its surface to x = 0.08, past the
   * rod at x = 0.05) */
  mr_pose p;
  mr_pose_identity(&p);
  p.translation[0] = 0.05;
  OK(mr_batch_set_driver_pose(b, hand, &p, 0.1));
  mr_pose_identity(&p);
  p.translation[0] = 0.23;
  OK(mr_batch_set_driver_pose(b, ball, &p, 0.3));
  const double dt = mr_batch_dt(b);
  OK(mr_batch_step(b, dt, 500));
  mr_state_view w;
  OK(mr_batch_state_view(b, &w));
  CHECK(w.node_position == v.node_position, "the view's pointer does not move");
  /* halfway, the root is halfway: linear interpolation between the poses */
  CHECK(fabs(x[first_slot] - 0.025) < 1e-12, "root x at t = 0.05: %.15g (0.025)", x[first_slot]);
  OK(mr_batch_step(b, dt, 500));
  CHECK(fabs(x[first_slot] - 0.05) < 1e-12, "root x at t = 0.1: %.15g (0.05)", x[first_slot]);
  CHECK(fabs(mr_batch_time(b) - 0.1) < 1e-12 && mr_batch_steps(b) == 1000, "time %g", mr_batch_time(b));

  /* a pose must be a rotation, and lie ahead */
  mr_pose_identity(&p);
  p.rotation[0] = 2;
  CHECK(mr_batch_set_driver_pose(b, hand, &p, 0.2) == MR_ERROR_INPUT && strstr(mr_last_error(), "rotation"),
        "an improper rotation: %s", mr_last_error());
  mr_pose_identity(&p);
  CHECK(mr_batch_set_driver_pose(b, hand, &p, 0.05) == MR_ERROR_INPUT && strstr(mr_last_error(), "before"),
        "a time in the past: %s", mr_last_error());
  CHECK(mr_batch_set_driver_pose(b, 7, &p, 0.2) == MR_ERROR_ARGUMENT, "driver out of range");

  /* the ball pushes the rod: after it passed x = 0.03 at t = 0.3 and stays
   * there, no node is inside it and the rod is bent away to +x */
  OK(mr_batch_step(b, dt, 3000));
  const double* y = x + v.component_stride;
  double rmin = 1e9, xmax = -1e9;
  for (size_t i = 0; i <= 20; ++i) {
    const size_t k = first_slot + i;
    const double dx = x[k] - 0.03, dy = y[k], dz = z[k] + 0.3;
    const double r = sqrt(dx * dx + dy * dy + dz * dz);
    if (r < rmin) rmin = r;
    if (x[k] > xmax) xmax = x[k];
  }
  /* contact keeps the centreline a rod radius (5 mm) out, to the contact
   * model's penetration: a small fraction of it */
  CHECK(rmin > 0.05 + 0.005 * 0.5, "closest node %g from the ball's centre (radius 0.05 + rod 0.005)", rmin);
  CHECK(xmax > 0.08, "the rod pushed past the ball's surface (x max %g)", xmax);

  /* positions as a host stores them: interleaved, all nodes */
  float buf[3 * 21];
  CHECK(mr_batch_copy_positions_f32(b, buf, 20) == MR_ERROR_ARGUMENT && strstr(mr_last_error(), "21"),
        "too small a buffer: %s", mr_last_error());
  OK(mr_batch_copy_positions_f32(b, buf, 21));
  for (size_t i = 0; i <= 20; ++i)
    CHECK(buf[3 * i] == (float)x[first_slot + i] && buf[3 * i + 2] == (float)z[first_slot + i], "node %zu", i);
  size_t fn, nn;
  OK(mr_batch_rod_nodes(b, 0, &fn, &nn));
  CHECK(fn == 0 && nn == 21, "rod 0's nodes");
  CHECK(mr_batch_rod_nodes(b, 1, &fn, &nn) == MR_ERROR_ARGUMENT, "rod 1 out of range");

  char saved[4200];
  snprintf(saved, sizeof saved, "%s/saved.h5", work);
  OK(mr_batch_save(b, saved));
  struct stat st;
  CHECK(stat(saved, &st) == 0 && st.st_size > 0, "saved");
  mr_batch_destroy(b);
}

/* Two rods described in C: a horizontal cantilever (undamped, energy
 * conserved) and a cable held at both ends whose tip the host drives. */
static void test_rods_in_c(void) {
  enum { N = 16 };
  double line[3 * (N + 1)], cable[3 * (N + 1)];
  for (int i = 0; i <= N; ++i) {
    line[3 * i] = 0.4 * i / N, line[3 * i + 1] = 0, line[3 * i + 2] = 0;
    cable[3 * i] = 0.3 * i / N, cable[3 * i + 1] = 0.2, cable[3 * i + 2] = 0;
  }
  mr_rod_desc rods[2];
  mr_default_rod_desc(&rods[0]);
  rods[0].elements = N;
  rods[0].nodes = line;
  rods[0].first_normal[0] = 0, rods[0].first_normal[2] = 1;
  rods[0].section_a = 0.005;
  mr_default_rod_desc(&rods[1]);
  rods[1].elements = N;
  rods[1].nodes = cable;
  rods[1].first_normal[0] = 0, rods[1].first_normal[2] = 1;
  rods[1].section_a = 0.002;
  rods[1].tip = MR_END_PINNED;
  rods[1].tip_driver = "connector";
  rods[1].tau_shear = rods[1].tau_extension = 0.01;
  mr_batch_settings s;
  mr_default_batch_settings(&s);

  /* bad rods name the rod */
  mr_batch* b = NULL;
  mr_rod_desc bad[2] = {rods[0], rods[1]};
  bad[1].elements = 0;
  CHECK(mr_batch_create(bad, 2, &s, &b) == MR_ERROR_INPUT && strstr(mr_last_error(), "rod 1") != NULL,
        "0 elements: %s", mr_last_error());
  double nan_line[3 * (N + 1)];
  memcpy(nan_line, line, sizeof line);
  nan_line[3 * 3 + 1] = NAN;
  bad[1] = rods[1];
  bad[0].nodes = nan_line;
  CHECK(mr_batch_create(bad, 2, &s, &b) == MR_ERROR_INPUT && strstr(mr_last_error(), "rod 0: node 3") != NULL,
        "a NaN node: %s", mr_last_error());
  bad[0] = rods[0];
  bad[0].tip_driver = "x";
  CHECK(mr_batch_create(bad, 2, &s, &b) == MR_ERROR_INPUT && strstr(mr_last_error(), "held tip") != NULL,
        "a driver on a free tip: %s", mr_last_error());
  CHECK(mr_batch_create(rods, 0, &s, &b) == MR_ERROR_ARGUMENT, "no rods");
  /* a first normal along the rod: the message names it, not a frame error */
  bad[0] = rods[0];
  bad[0].first_normal[0] = 1, bad[0].first_normal[2] = 0;
  CHECK(mr_batch_create(bad, 2, &s, &b) == MR_ERROR_INPUT && strstr(mr_last_error(), "rod 0") != NULL &&
            strstr(mr_last_error(), "first_normal") != NULL && strstr(mr_last_error(), "parallel") != NULL,
        "a normal along the rod: %s", mr_last_error());
  /* the default first normal (0, 0, 0): one is chosen, for a rod along x too */
  bad[0] = rods[0];
  mr_default_rod_desc(&bad[0]);
  bad[0].elements = N;
  bad[0].nodes = line;
  OK(mr_batch_create(bad, 1, &s, &b));
  mr_batch_destroy(b);
  b = NULL;

  OK(mr_batch_create(rods, 2, &s, &b));
  CHECK(mr_batch_node_count(b) == 2 * (N + 1) && mr_batch_driver_count(b) == 1, "nodes and drivers");
  size_t fn, nn;
  OK(mr_batch_rod_nodes(b, 1, &fn, &nn));
  CHECK(fn == N + 1 && nn == N + 1, "rod 1's nodes follow rod 0's");

  /* Position Verlet conserves a modified energy: the true energy of a mode
   * of frequency ω oscillates by the relative (ω h / 2)² about it. With
   * h = 0.1 × 2/ω_max that is at most 1e-2 for any mode, of the energy the
   * motion exchanges (the potential energy released). */
  const double h = 0.1 * mr_batch_stable_dt(b);
  mr_energies e0, e1;
  OK(mr_batch_energies(b, 0, &e0));
  double worst = 0, released = 0;
  for (int k = 0; k < 50; ++k) {
    OK(mr_batch_step(b, h, 40));
    OK(mr_batch_energies(b, 0, &e1));
    const double d = fabs((e1.kinetic + e1.elastic + e1.potential) - (e0.kinetic + e0.elastic + e0.potential));
    if (d > worst) worst = d;
    if (e0.potential - e1.potential > released) released = e0.potential - e1.potential;
  }
  CHECK(released > 0, "the cantilever falls");
  CHECK(worst <= 1e-2 * released, "energy drift %g of %g released", worst, released);

  /* the connector moves the cable's tip 5 cm along y over 0.05 s */
  size_t c = 9;
  OK(mr_batch_find_driver(b, "connector", &c));
  mr_pose p;
  mr_pose_identity(&p);
  p.translation[1] = 0.05;
  const double t0 = mr_batch_time(b);
  OK(mr_batch_set_driver_pose(b, c, &p, t0 + 0.05));
  const int steps = (int)ceil(0.05 / h);
  OK(mr_batch_step(b, 0.05 / steps, steps));
  double xyz[3 * 2 * (N + 1)];
  OK(mr_batch_copy_positions_f64(b, xyz, 2 * (N + 1)));
  const double* tip = xyz + 3 * (2 * N + 1);
  CHECK(fabs(tip[0] - 0.3) < 1e-12 && fabs(tip[1] - 0.25) < 1e-12 && fabs(tip[2]) < 1e-12,
        "the driven tip at (%.15g, %.15g, %.15g)", tip[0], tip[1], tip[2]);
  /* then a quarter turn about z about the tip's own body point (0.3, 0.2, 0),
   * keeping the 5 cm: the pivot's image stays at (0.3, 0.25, 0) during the
   * move, so the pinned tip does not leave it */
  const double pivot[3] = {0.3, 0.2, 0};
  double rz[9] = {0, -1, 0, 1, 0, 0, 0, 0, 1};
  memcpy(p.rotation, rz, sizeof rz);
  const double t1 = mr_batch_time(b);
  OK(mr_batch_set_driver_pose_about(b, c, &p, pivot, t1 + 0.05));
  for (int k = 0; k < 5; ++k) {
    OK(mr_batch_step(b, 0.05 / steps, steps / 5));
    OK(mr_batch_copy_positions_f64(b, xyz, 2 * (N + 1)));
    CHECK(fabs(tip[0] - 0.3) < 1e-12 && fabs(tip[1] - 0.25) < 1e-12 && fabs(tip[2]) < 1e-12,
          "the tip at the pivot during the turn at (%.15g, %.15g, %.15g)", tip[0], tip[1], tip[2]);
  }
  CHECK(mr_batch_set_driver_pose_about(b, c, &p, NULL, t1 + 1) == MR_ERROR_ARGUMENT, "a NULL pivot");

  /* results do not depend on the thread count */
  mr_batch *one = NULL, *two = NULL;
  OK(mr_batch_create(rods, 2, &s, &one));
  OK(mr_batch_create(rods, 2, &s, &two));
  OK(mr_batch_set_threads(two, 2));
  CHECK(mr_batch_set_threads(two, 0) == MR_ERROR_ARGUMENT, "0 threads");
  OK(mr_batch_step(one, h, 300));
  OK(mr_batch_step(two, h, 300));
  CHECK(mr_batch_state_hash(one) == mr_batch_state_hash(two), "1 and 2 threads agree");

  /* a step above the stable one is refused before it runs, as `manyrods
   * run` refuses it: the message gives the limit and the override; the
   * state is untouched */
  const uint64_t before = mr_batch_state_hash(one);
  mr_status st = mr_batch_step(one, 10 * mr_batch_stable_dt(one), 10);
  CHECK(st == MR_ERROR_INPUT && strstr(mr_last_error(), "stable limit") != NULL &&
            strstr(mr_last_error(), "mr_batch_set_force_dt") != NULL,
        "status %d: %s", (int)st, mr_last_error());
  CHECK(mr_batch_state_hash(one) == before && mr_batch_steps(one) == 300, "a refused step leaves the state");
  CHECK(mr_batch_set_force_dt(one, 2) == MR_ERROR_ARGUMENT, "force_dt is 0 or 1");
  /* forced far above the stable step: a non-finite state, reported */
  OK(mr_batch_set_force_dt(one, 1));
  st = mr_batch_step(one, 200 * mr_batch_stable_dt(one), 2000);
  CHECK(st == MR_ERROR_NON_FINITE && strlen(mr_last_error()) > 0, "status %d", (int)st);
  CHECK(mr_batch_step(one, -1.0, 1) == MR_ERROR_ARGUMENT, "a negative dt");
  mr_batch_destroy(one);
  mr_batch_destroy(two);
  mr_batch_destroy(b);
}

/* Loads the host writes: a force on the tip of a weightless rod pushes it. */
static void test_loads(void) {
  enum { N = 8 };
  double line[3 * (N + 1)];
  for (int i = 0; i <= N; ++i) line[3 * i] = 0.2 * i / N, line[3 * i + 1] = line[3 * i + 2] = 0;
  mr_rod_desc r;
  mr_default_rod_desc(&r);
  r.elements = N;
  r.nodes = line;
  r.first_normal[0] = 0, r.first_normal[2] = 1;
  mr_batch_settings s;
  mr_default_batch_settings(&s);
  s.precision = MR_FLOAT;
  s.gravity[2] = 0;
  mr_batch* b = NULL;
  OK(mr_batch_create(&r, 1, &s, &b));
  mr_loads_view l;
  OK(mr_batch_loads_view(b, &l));
  mr_state_view v;
  OK(mr_batch_state_view(b, &v));
  CHECK(l.precision == MR_FLOAT && v.precision == MR_FLOAT, "float batch");
  size_t first;
  int elements;
  OK(mr_batch_rod_slots(b, 0, &first, &elements));
  float* f = (float*)l.node_force;
  f[2 * l.component_stride + first + N] = 1e-3f; /* +z on the tip */
  OK(mr_batch_step(b, 0.9 * mr_batch_stable_dt(b), 200));
  const float* z = (const float*)v.node_position + 2 * v.component_stride;
  CHECK(z[first + N] > 0, "the tip moved along the force (z = %g)", z[first + N]);
  mr_batch_destroy(b);
}

/* A cable clamped at both ends, its tip brought 0.4 m closer over 1 s. */
static const char* kCableScene =
    "[simulation]\n"
    "dt = \"auto\"\n"
    "duration = 1.5\n"
    "output_interval = 0.05\n"
    "gravity = [0.0, 0.0, -9.81]\n"
    "[[rods]]\n"
    "name = \"cable\"\n"
    "elements = 40\n"
    "length = 2.0\n"
    "direction = [1.0, 0.0, 0.0]\n"
    "normal = [0.0, 0.0, 1.0]\n"
    "section = { shape = \"circle\", radius = 0.004 }\n"
    "material = { density = 1400.0, youngs_modulus = 5.0e7, poisson_ratio = 0.45 }\n"
    "root = \"clamped\"\n"
    "tip = { kind = \"clamped\", motion = \"ramp\", translation = [-0.4, 0.0, 0.0], duration = 1.0 }\n";

/* The static equilibrium at t = 1 s: the clamps carry the weight, half
 * each (to the solve's residual); a free rod is a mechanism (an input
 * error naming the rod). */
static void test_statics(void) {
  mr_batch* b = NULL;
  OK(mr_batch_create_from_scene(write_file("cable.toml", kCableScene), &b));
  mr_static_result r;
  OK(mr_batch_solve_static(b, 1.0, &r));
  CHECK(r.converged == 1 && r.failed_rod == -1 && r.residual_force < 1e-9, "converged (residual %g N)",
        r.residual_force);
  CHECK(mr_batch_time(b) == 1.0, "the batch's time is the holds' (%g)", mr_batch_time(b));
  size_t count = 0;
  OK(mr_batch_hold_reactions(b, NULL, &count));
  CHECK(count == 2, "two holds (%zu)", count);
  mr_hold_reaction h[2];
  size_t one = 1;
  CHECK(mr_batch_hold_reactions(b, h, &one) == MR_ERROR_ARGUMENT && one == 2, "a short capacity is refused");
  OK(mr_batch_hold_reactions(b, h, &count));
  const double weight = 1400 * 3.141592653589793 * 0.004 * 0.004 * 2.0 * 9.81;
  CHECK(h[0].node == 0 && h[1].node == 40 && h[0].clamped && h[1].clamped, "root and tip clamps");
  CHECK(fabs(h[0].force[2] - weight / 2) < 1e-9 * weight && fabs(h[1].force[2] - weight / 2) < 1e-9 * weight,
        "half the weight each (%g, %g of %g N)", h[0].force[2], h[1].force[2], weight);
  mr_batch_destroy(b);
  char free_rod[2048];
  snprintf(free_rod, sizeof free_rod, "%s", kCableScene);
  snprintf(strstr(free_rod, "root = "), 32, "root = \"free\"\n");  /* (the default root is clamped) */
  OK(mr_batch_create_from_scene(write_file("free.toml", free_rod), &b));
  const mr_status st = mr_batch_solve_static(b, NAN, &r);
  CHECK(st == MR_ERROR_INPUT && r.mechanism == 1 && r.converged == 0,
        "a free rod in gravity is a mechanism (status %d, converged %d, mechanism %d)", (int)st, r.converged, r.mechanism);
  CHECK(strstr(mr_last_error(), "free to move under its loads") != NULL, "the message: %s", mr_last_error());
  mr_batch_destroy(b);
}

/* Rod-rod contact in the static solve: a heavy cable (rho = 2800) across a
 * light one (1400), touching at their middles, clamped at both ends. The
 * four clamps carry both weights (the push between them is internal, an
 * independent balance), to 1e-8; the light cable's clamps carry more than
 * its weight. */
static void test_statics_rod_contact(void) {
  static const char* scene =
      "[simulation]\ndt = \"auto\"\nduration = 1.0\ngravity = [0.0, 0.0, -9.81]\n"
      "[contact]\nrod_rod = true\n"
      "[[rods]]\nname = \"heavy\"\nelements = 40\nlength = 1.0\nstart = [0.0, 0.0, 0.008]\n"
      "direction = [1.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\nsection = { shape = \"circle\", radius = 0.004 }\n"
      "material = { density = 2800.0, youngs_modulus = 5.0e7, poisson_ratio = 0.45 }\nroot = \"clamped\"\ntip = \"clamped\"\n"
      "[[rods]]\nname = \"light\"\nelements = 40\nlength = 1.0\nstart = [0.5, -0.5, 0.0]\n"
      "direction = [0.0, 1.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\nsection = { shape = \"circle\", radius = 0.004 }\n"
      "material = { density = 1400.0, youngs_modulus = 5.0e7, poisson_ratio = 0.45 }\nroot = \"clamped\"\ntip = \"clamped\"\n";
  mr_batch* b = NULL;
  OK(mr_batch_create_from_scene(write_file("crossing.toml", scene), &b));
  mr_static_result r;
  OK(mr_batch_solve_static(b, NAN, &r));
  CHECK(r.converged == 1, "converged (residual %g N)", r.residual_force);
  mr_hold_reaction h[4];
  size_t count = 4;
  OK(mr_batch_hold_reactions(b, h, &count));
  CHECK(count == 4, "four clamps (%zu)", count);
  const double area = 3.141592653589793 * 0.004 * 0.004, heavy = 2800 * area * 9.81, light = 1400 * area * 9.81;
  const double on_light = h[2].force[2] + h[3].force[2], all = h[0].force[2] + h[1].force[2] + on_light;
  CHECK(fabs(all - heavy - light) < 1e-8 * heavy, "the clamps carry both weights (%g of %g N)", all, heavy + light);
  CHECK(on_light > 1.05 * light, "the heavy cable presses on the light one (%g N on its clamps, its weight %g N)",
        on_light, light);
  mr_batch_destroy(b);
}

/* Friction at a collider in the static solve: a cable clamped at one end
 * lying on a bench (friction 0.4), pulled across at its tip by a tenth of
 * its weight. Every node but the clamped one presses on the bench and is
 * counted as sticking or slipping; the clamp carries less of the pull than
 * on a frictionless bench (where it carries all of it: an independent
 * balance), the bench's friction the rest. */
static void test_statics_friction(void) {
  const double weight = 1400 * 3.141592653589793 * 0.005 * 0.005 * 1.0 * 9.81;
  double clamp_y[2] = {0, 0};
  for (int friction = 1; friction >= 0; --friction) {
    char scene[2048];
    snprintf(scene, sizeof scene,
             "[simulation]\ndt = \"auto\"\nduration = 1.0\ngravity = [0.0, 0.0, -9.81]\n"
             "[[colliders]]\nkind = \"plane\"\npoint = [0.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\n%s\n"
             "[[rods]]\nname = \"cable\"\nelements = 40\nlength = 1.0\nstart = [0.0, 0.0, 0.005]\n"
             "direction = [1.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\nsection = { shape = \"circle\", radius = 0.005 }\n"
             "material = { density = 1400.0, youngs_modulus = 5.0e7, poisson_ratio = 0.45 }\nroot = \"clamped\"\n"
             "tip_force = [0.0, %.17g, 0.0]\n",
             friction ? "friction = { static = 0.4, kinetic = 0.4 }" : "", 0.1 * weight);
    mr_batch* b = NULL;
    OK(mr_batch_create_from_scene(write_file(friction ? "bench.toml" : "slick.toml", scene), &b));
    mr_static_result r;
    OK(mr_batch_solve_static(b, NAN, &r));
    CHECK(r.converged == 1, "converged (residual %g N)", r.residual_force);
    CHECK(friction ? r.sticking + r.slipping == 40 : r.sticking + r.slipping == 0,
          "nodes held by friction: %d stick, %d slip", r.sticking, r.slipping);
    mr_hold_reaction h[1];
    size_t count = 1;
    OK(mr_batch_hold_reactions(b, h, &count));
    clamp_y[friction] = -h[0].force[1];
    mr_batch_destroy(b);
  }
  CHECK(fabs(clamp_y[0] - 0.1 * weight) < 1e-8 * weight && clamp_y[1] < 0.9 * clamp_y[0],
        "the clamp carries the pull on a frictionless bench (%g of %g N), less with friction (%g N)", clamp_y[0],
        0.1 * weight, clamp_y[1]);
}

/* Gravity preload: a rod of 20 cm held out sideways (below its lateral-torsional
 * buckling load) stands as built; a free one has none; a long one standing
 * up is an unstable equilibrium, refused. */
static void test_preload(void) {
  enum { N = 16 };
  double line[3 * (N + 1)];
  for (int i = 0; i <= N; ++i) line[3 * i] = 0.2 * i / N, line[3 * i + 1] = 0, line[3 * i + 2] = 0;
  mr_rod_desc rod;
  mr_default_rod_desc(&rod);
  rod.elements = N;
  rod.nodes = line;
  rod.preload = 1;
  mr_batch_settings s;
  mr_default_batch_settings(&s);
  mr_batch* b = NULL;
  OK(mr_batch_create(&rod, 1, &s, &b));
  OK(mr_batch_step(b, 1e-5, 2000));
  double x[3 * (N + 1)];
  OK(mr_batch_copy_positions_f64(b, x, N + 1));
  double drift = 0;
  for (int i = 0; i < 3 * (N + 1); ++i) drift = fmax(drift, fabs(x[i] - line[i]));
  CHECK(drift < 1e-12, "a preloaded rod stays as built (drift %g m)", drift);
  int rods = 0, contacts = -1;
  OK(mr_batch_preload(b, &rods, &contacts));
  CHECK(rods == 1 && contacts == 0, "preloaded again (%d rods, %d contacts)", rods, contacts);
  mr_batch_destroy(b);
  rod.root = MR_END_FREE;
  CHECK(mr_batch_create(&rod, 1, &s, &b) == MR_ERROR_INPUT && strstr(mr_last_error(), "preload") != NULL,
        "a free rod has no preload: %s", mr_last_error());
  /* standing up 50 cm from a clamped root: beyond its buckling length under
   * its own weight (Greenhill's qL^3/EI = 7.837 at about 27 cm), so the
   * preload's equilibrium is an unstable one, refused */
  for (int i = 0; i <= N; ++i) line[3 * i] = 0, line[3 * i + 1] = 0, line[3 * i + 2] = 0.5 * i / N;
  rod.root = MR_END_CLAMPED;
  rod.first_normal[0] = 1, rod.first_normal[1] = 0, rod.first_normal[2] = 0;
  CHECK(mr_batch_create(&rod, 1, &s, &b) == MR_ERROR_INPUT && strstr(mr_last_error(), "unstable") != NULL,
        "a column beyond its buckling length is refused: %s", mr_last_error());
  /* 15 cm standing up stands; a downward tip load of 2 N (Euler's load for
   * the clamped-free column, pi^2 EI / 4L^2, is 0.86 N) makes the
   * equilibrium unstable: mr_batch_preload refuses it and keeps the rest
   * shape (with the load taken off again the column still stands) */
  for (int i = 0; i <= N; ++i) line[3 * i + 2] = 0.15 * i / N;
  OK(mr_batch_create(&rod, 1, &s, &b));
  mr_loads_view l;
  OK(mr_batch_loads_view(b, &l));
  size_t first;
  int elements;
  OK(mr_batch_rod_slots(b, 0, &first, &elements));
  double* f = (double*)l.node_force;
  f[2 * l.component_stride + first + N] = -2.0;
  CHECK(mr_batch_preload(b, NULL, NULL) == MR_ERROR_INPUT && strstr(mr_last_error(), "unstable") != NULL,
        "mr_batch_preload refuses an unstable equilibrium: %s", mr_last_error());
  f[2 * l.component_stride + first + N] = 0.0;
  OK(mr_batch_step(b, 1e-5, 2000));
  OK(mr_batch_copy_positions_f64(b, x, N + 1));
  drift = 0;
  for (int i = 0; i < 3 * (N + 1); ++i) drift = fmax(drift, fabs(x[i] - line[i]));
  CHECK(drift < 1e-12, "the refused preload kept the rest shape (drift %g m)", drift);
  mr_batch_destroy(b);
}

int main(int argc, char** argv) {
  if (argc < 2) {
    fprintf(stderr, "usage: test_c_api WORK_DIR [MANYRODS_CLI]\n");
    return 2;
  }
  snprintf(work, sizeof work, "%s", argv[1]);
  mkdir(work, 0755);
  test_versions();
  test_errors();
  test_thread_local_error();
  test_scene(argc > 2 ? argv[2] : NULL);
  test_rods_in_c();
  test_loads();
  test_statics();
  test_statics_rod_contact();
  test_statics_friction();
  test_preload();
  printf("test_c_api: %d checks passed\n", checks);
  return 0;
}
