/* examples/c/host_loop.c — a host application's frame loop over the C API
 * (include/manyrods/manyrods_c.h, docs/c_api.md): load a scene, and at each
 * frame set the head's pose for the end of the frame, step to it, and read
 * the hair's positions — once as the host's own interleaved float buffer
 * (a copy, what Houdini, Maya and Blender store) and once without a copy
 * from the library's arrays.
 *
 *   host_loop SCENE.toml [FRAMES]        (examples/c/head.toml) */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "manyrods/manyrods_c.h"

static const double kPi = 3.14159265358979323846;

static int check(mr_status s, const char* what) {
  if (s == MR_OK) return 0;
  fprintf(stderr, "host_loop: %s: %s\n", what, mr_last_error());
  return 1;
}

int main(int argc, char** argv) {
  if (argc < 2) {
    fprintf(stderr, "usage: host_loop SCENE.toml [FRAMES]\n");
    return 2;
  }
  if (mr_abi_version() != MR_ABI_VERSION) {
    fprintf(stderr, "host_loop: built against manyrods ABI %d, running with %d\n", MR_ABI_VERSION, mr_abi_version());
    return 1;
  }
  const int frames = argc > 2 ? atoi(argv[2]) : 24;
  mr_batch* b = NULL;
  if (check(mr_batch_create_from_scene(argv[1], &b), argv[1])) return 1;
  size_t head = 0;
  if (check(mr_batch_find_driver(b, "head", &head), "the scene's host motion")) return 1;

  const double fps = 24, dt = mr_batch_dt(b);
  const int substeps = (int)ceil(1 / (fps * dt)); /* steps per frame, at most the scene's dt */
  const size_t nodes = mr_batch_node_count(b);
  float* host_points = malloc(3 * nodes * sizeof *host_points); /* the host's own buffer */
  mr_state_view view;
  if (!host_points || check(mr_batch_state_view(b, &view), "state view")) return 1;
  size_t tip_slot;
  int elements;
  if (check(mr_batch_rod_slots(b, 0, &tip_slot, &elements), "rod 0")) return 1;
  tip_slot += (size_t)elements;
  printf("manyrods %s: %zu rods, %zu nodes, %d steps of %.3g s per frame\n", mr_version_string(),
         mr_batch_rod_count(b), nodes, substeps, 1 / (fps * substeps));
  printf("frame  head angle (deg)  rod 0 tip (m)\n");

  for (int f = 1; f <= frames; ++f) {
    /* the rig: the head turns +-40 degrees about z at 0.8 Hz, eased in */
    const double t = f / fps, ease = t < 0.3 ? t / 0.3 : 1;
    const double a = ease * 40 * kPi / 180 * sin(2 * kPi * 0.8 * t);
    mr_pose p;
    mr_pose_identity(&p);
    p.rotation[0] = cos(a), p.rotation[1] = -sin(a);
    p.rotation[3] = sin(a), p.rotation[4] = cos(a);
    if (check(mr_batch_set_driver_pose(b, head, &p, t), "set the head's pose")) return 1;
    if (check(mr_batch_step(b, 1 / (fps * substeps), substeps), "step")) return 1;
    /* the copy a host keeps, and the same tip read in place */
    if (check(mr_batch_copy_positions_f32(b, host_points, nodes), "copy positions")) return 1;
    const double* x = view.precision == MR_DOUBLE ? (const double*)view.node_position : NULL;
    if (x && f % 4 == 0)
      printf("%5d  %16.1f  (%.4f, %.4f, %.4f)\n", f, a * 180 / kPi, x[tip_slot], x[view.component_stride + tip_slot],
             x[2 * view.component_stride + tip_slot]);
  }
  printf("state hash %016llx\n", (unsigned long long)mr_batch_state_hash(b));
  free(host_points);
  mr_batch_destroy(b);
  return 0;
}
