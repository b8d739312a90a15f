/* The public header is C: this file is compiled as C99 and linked against the shared library. It
 * checks the header's promise that every call returning a negative status sets the message of
 * modalrt_last_error_message(), with the status the header lists: one failing call of each function,
 * and after each the message must name that function (or, for a load, the file), so a message left
 * over from the previous call cannot pass. The basis is the lattice written by write_test_basis
 * (argv[1]). */
#include <modalrt/modalrt.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int failures = 0;

/* Counting allocator hooks: every block the library takes must come back, with its size. */
static long   hook_allocations = 0, hook_frees = 0;
static size_t hook_bytes = 0;

static void *counting_allocate(size_t bytes, size_t alignment, void *user)
{
  (void)user;
  if (alignment > 16) /* malloc's guarantee on this platform */
    return NULL;
  ++hook_allocations;
  hook_bytes += bytes;
  return malloc(bytes > 0 ? bytes : 1);
}

static void counting_deallocate(void *pointer, size_t bytes, size_t alignment, void *user)
{
  (void)alignment;
  (void)user;
  ++hook_frees;
  hook_bytes -= bytes;
  free(pointer);
}

static void expect_failure(int status, int expected, const char *culprit, const char *call)
{
  const char *message = modalrt_last_error_message();
  if (status != expected || message == NULL || strstr(message, culprit) == NULL)
    {
      ++failures;
      fprintf(stderr, "FAILED: %s returned %s (expected %s), message '%s' (should name '%s')\n", call,
              modalrt_status_name(status), modalrt_status_name(expected), message ? message : "(null)", culprit);
    }
  else
    printf("  %-60s %-32s %s\n", call, modalrt_status_name(status), message);
}

#define EXPECT_FAILURE(call, expected, culprit) expect_failure((call), (expected), (culprit), #call)
#define CHECK(condition)                                                                                               \
  do                                                                                                                   \
    {                                                                                                                  \
      if (!(condition))                                                                                                \
        {                                                                                                              \
          ++failures;                                                                                                  \
          fprintf(stderr, "FAILED: %s\n", #condition);                                                                 \
        }                                                                                                              \
    }                                                                                                                  \
  while (0)

int main(int argc, char **argv)
{
  modalrt_basis      *basis  = NULL;
  modalrt_kernel     *kernel = NULL, *bad = NULL;
  modalrt_snapshot   *snapshot = NULL;
  modalrt_kernel_def  def    = modalrt_kernel_default_def();
  modalrt_device_def  device = modalrt_device_default_def();
  modalrt_frame_state frame  = modalrt_frame_state_identity();
  modalrt_basis_info  info;
  modalrt_space_info  space_info;
  modalrt_section_info section;
  modalrt_verify_case  verify_case;
  modalrt_kernel_stats stats;
  modalrt_snapshot_info snapshot_info;
  modalrt_hip_input   input;
  modalrt_hip_output  output;
  double              compliance[9], q[1], weights[3] = {1.0, 0.0, 0.0};
  float               surface[3];
  uint32_t            modes = 0;
  const char          *path  = argc > 1 ? argv[1] : "c_api_lattice.mrt";
  modalrt_allocator    hooks = {counting_allocate, counting_deallocate, NULL};
  modalrt_allocator    half  = {counting_allocate, NULL, NULL};

  /* Allocator hooks, set at load time (nothing exists yet). */
  EXPECT_FAILURE(modalrt_set_allocator(&half), MODALRT_ERROR_INVALID_ARGUMENT, "modalrt_set_allocator");
  CHECK(modalrt_set_allocator(&hooks) == MODALRT_OK);

  /* The defaults the header writes in brackets. */
  CHECK(def.time_step == 1e-3 && def.hip_capacity == 4 && def.coupling_stiffness == 1000.0 &&
        def.coupling_damping == 2.0 && def.snap_distance == 0.01 && def.release_distance == 1e-3 &&
        def.release_drag_distance == 0.01 && def.fail_safe_hold == 0.5 && def.fail_safe_ramp == 0.05 &&
        def.max_input_velocity == 100.0 && def.workspace_radius == 10.0 && def.validity_level == 0 && def.validity_clamp == 0);
  CHECK(device.max_force == 10.0 && device.max_stiffness == 3000.0 && device.max_damping == 10.0 &&
        def.device.max_force == device.max_force && frame.orientation[0] == 1.0);
  CHECK(strcmp(modalrt_status_name(MODALRT_ERROR_CHECKSUM), "MODALRT_ERROR_CHECKSUM") == 0);
  CHECK(modalrt_version() == MODALRT_VERSION_MAJOR * 1000u + MODALRT_VERSION_MINOR);

  /* Basis. */
  EXPECT_FAILURE(modalrt_basis_load("/nonexistent.mrt", &basis), MODALRT_ERROR_IO, "/nonexistent.mrt");
  CHECK(basis == NULL);
  EXPECT_FAILURE(modalrt_basis_load(NULL, &basis), MODALRT_ERROR_INVALID_ARGUMENT, "modalrt_basis_load");
  EXPECT_FAILURE(modalrt_basis_load_memory(NULL, 5, &basis), MODALRT_ERROR_INVALID_ARGUMENT, "modalrt_basis_load_memory");
  EXPECT_FAILURE(modalrt_basis_load_memory("MRT", 3, &basis), MODALRT_ERROR_FORMAT, "<memory>");
  if (modalrt_basis_load(path, &basis) != MODALRT_OK)
    {
      fprintf(stderr, "cannot load %s: %s\n", path, modalrt_last_error_message());
      return 1;
    }
  CHECK(hook_allocations > 10 && hook_bytes > 1000); /* the basis's arrays came from the hooks */
  EXPECT_FAILURE(modalrt_set_allocator(NULL), MODALRT_ERROR_STATE, "modalrt_set_allocator");
  EXPECT_FAILURE(modalrt_basis_get_info(NULL, &info), MODALRT_ERROR_INVALID_ARGUMENT, "modalrt_basis_get_info");
  EXPECT_FAILURE(modalrt_basis_get_space_info(basis, 99, &space_info), MODALRT_ERROR_INVALID_ARGUMENT,
                 "modalrt_basis_get_space_info");
  EXPECT_FAILURE(modalrt_basis_contact_compliance(basis, 0, 0xFFFFFFu, compliance, NULL), MODALRT_ERROR_INVALID_ARGUMENT,
                 "modalrt_basis_contact_compliance");
  EXPECT_FAILURE(modalrt_basis_point_compliance(basis, 0, 0xFFFFFFu, weights, compliance, NULL),
                 MODALRT_ERROR_INVALID_ARGUMENT, "modalrt_basis_point_compliance");
  EXPECT_FAILURE(modalrt_basis_pair_coupling(basis, 0, 0, 0xFFFFFFu, compliance), MODALRT_ERROR_INVALID_ARGUMENT,
                 "modalrt_basis_pair_coupling");
  EXPECT_FAILURE(modalrt_basis_get_section(basis, 9999, &section), MODALRT_ERROR_INVALID_ARGUMENT,
                 "modalrt_basis_get_section");
  EXPECT_FAILURE(modalrt_basis_verify_case(basis, 99999, &verify_case), MODALRT_ERROR_INVALID_ARGUMENT,
                 "validation case 99999");
  CHECK(strstr(modalrt_last_error_message(), "modalrt_basis_verify_case: ") != NULL); /* the function */
  CHECK(strstr(modalrt_last_error_message(), argv[1]) != NULL);                        /* and the file */
  EXPECT_FAILURE(modalrt_basis_verify(NULL, NULL), MODALRT_ERROR_INVALID_ARGUMENT, "modalrt_basis_verify");

  /* Kernel definition. */
  def.time_step = 0.0;
  EXPECT_FAILURE(modalrt_kernel_create(basis, &def, &bad), MODALRT_ERROR_INVALID_ARGUMENT, "time_step");
  def           = modalrt_kernel_default_def();
  def.validity_level = 3;
  EXPECT_FAILURE(modalrt_kernel_create(basis, &def, &bad), MODALRT_ERROR_INVALID_ARGUMENT, "validity_level");
  def                = modalrt_kernel_default_def();
  def.validity_clamp = 2;
  EXPECT_FAILURE(modalrt_kernel_create(basis, &def, &bad), MODALRT_ERROR_INVALID_ARGUMENT, "validity_clamp");
  def                    = modalrt_kernel_default_def();
  def.coupling_stiffness = 5000.0;
  EXPECT_FAILURE(modalrt_kernel_create(basis, &def, &bad), MODALRT_ERROR_DEVICE_LIMIT, "max_stiffness");
  def = modalrt_kernel_default_def();
  EXPECT_FAILURE(modalrt_kernel_create(NULL, &def, &bad), MODALRT_ERROR_INVALID_ARGUMENT, "modalrt_kernel_create");
  CHECK(bad == NULL);
  def.hip_capacity = 1;
  CHECK(modalrt_kernel_create(basis, &def, &kernel) == MODALRT_OK);
  if (!kernel)
    return 1;

  /* Kernel calls. */
  memset(&input, 0, sizeof input);
  input.position[2] = 1.0;
  EXPECT_FAILURE(modalrt_kernel_reset(NULL), MODALRT_ERROR_INVALID_ARGUMENT, "modalrt_kernel_reset");
  EXPECT_FAILURE(modalrt_kernel_tick_admittance(NULL, &input, 1, &output), MODALRT_ERROR_INVALID_ARGUMENT,
                 "modalrt_kernel_tick_admittance");
  EXPECT_FAILURE(modalrt_kernel_tick_impedance(NULL, &input, 1, &output), MODALRT_ERROR_INVALID_ARGUMENT,
                 "modalrt_kernel_tick_impedance");
  EXPECT_FAILURE(modalrt_kernel_tick_impedance(kernel, NULL, 1, &output), MODALRT_ERROR_INVALID_ARGUMENT,
                 "modalrt_kernel_tick");
  EXPECT_FAILURE(modalrt_kernel_tick_missing(kernel, 5, &output), MODALRT_ERROR_INVALID_ARGUMENT,
                 "modalrt_kernel_tick_missing");
  frame.linear_acceleration[0] = NAN;
  EXPECT_FAILURE(modalrt_kernel_set_frame(kernel, &frame), MODALRT_ERROR_VALUE, "modalrt_kernel_set_frame");
  EXPECT_FAILURE(modalrt_kernel_contact_begin(kernel, 7, 0), MODALRT_ERROR_INVALID_ARGUMENT, "modalrt_kernel_contact_begin");
  EXPECT_FAILURE(modalrt_kernel_release_hip(kernel, 7), MODALRT_ERROR_INVALID_ARGUMENT, "modalrt_kernel_release_hip");
  EXPECT_FAILURE(modalrt_kernel_switch_space(kernel, 99), MODALRT_ERROR_INVALID_ARGUMENT, "modalrt_kernel_switch_space");
  input.force[0] = INFINITY;
  EXPECT_FAILURE(modalrt_kernel_settle(kernel, &input, 1), MODALRT_ERROR_VALUE, "modalrt_kernel_settle");
  EXPECT_FAILURE(modalrt_kernel_get_modal_state(kernel, q, NULL, 0, &modes), MODALRT_ERROR_INVALID_ARGUMENT,
                 "modalrt_kernel_get_modal_state");
  EXPECT_FAILURE(modalrt_kernel_get_stats(kernel, NULL), MODALRT_ERROR_INVALID_ARGUMENT, "modalrt_kernel_get_stats");

  /* A rejected tick is not an error: it keeps the message and returns the fail-safe status. */
  input.force[0] = 0.0;
  input.position[0] = 1e30;
  CHECK(modalrt_kernel_tick_impedance(kernel, &input, 1, &output) == MODALRT_INPUT_REJECTED);
  CHECK((output.flags & MODALRT_HIP_FAIL_SAFE) != 0);
  CHECK(strstr(modalrt_last_error_message(), "modalrt_kernel_get_stats") != NULL);
  CHECK(modalrt_kernel_tick_missing(kernel, 1, &output) == MODALRT_INPUT_REJECTED);
  CHECK(modalrt_kernel_get_stats(kernel, &stats) == MODALRT_OK && stats.missing_ticks == 1 && stats.rejected_ticks == 1 &&
        stats.fail_safe_run == 2);

  /* Display. */
  EXPECT_FAILURE(modalrt_snapshot_create(NULL, &snapshot), MODALRT_ERROR_INVALID_ARGUMENT, "modalrt_snapshot_create");
  CHECK(modalrt_snapshot_create(kernel, &snapshot) == MODALRT_OK);
  EXPECT_FAILURE(modalrt_kernel_snapshot_read(kernel, NULL), MODALRT_ERROR_INVALID_ARGUMENT, "modalrt_kernel_snapshot_read");
  {
    /* A snapshot of another kernel with the same basis and capacities is refused (it was accepted). */
    modalrt_kernel   *other          = NULL;
    modalrt_snapshot *other_snapshot = NULL;
    modalrt_kernel_def same          = def; /* the same capacities */
    CHECK(modalrt_kernel_create(basis, &same, &other) == MODALRT_OK);
    CHECK(modalrt_snapshot_create(other, &other_snapshot) == MODALRT_OK);
    EXPECT_FAILURE(modalrt_kernel_snapshot_read(kernel, other_snapshot), MODALRT_ERROR_INVALID_ARGUMENT,
                   "created for another kernel");
    CHECK(modalrt_kernel_snapshot_read(other, other_snapshot) >= 0);
    modalrt_snapshot_destroy(other_snapshot);
    modalrt_kernel_destroy(other);
  }
  {
    /* modalrt_snapshot_get_contacts says what was wrong. */
    uint32_t count = 0;
    EXPECT_FAILURE(modalrt_snapshot_get_contacts(snapshot, 1, NULL, NULL, &count), MODALRT_ERROR_INVALID_ARGUMENT,
                   "null vertices or corrections with capacity > 0");
    EXPECT_FAILURE(modalrt_snapshot_get_contacts(NULL, 0, NULL, NULL, &count), MODALRT_ERROR_INVALID_ARGUMENT,
                   "null snapshot or count");
  }
  EXPECT_FAILURE(modalrt_snapshot_get_info(NULL, &snapshot_info), MODALRT_ERROR_INVALID_ARGUMENT, "modalrt_snapshot_get_info");
  modalrt_basis_get_info(basis, &info);
  EXPECT_FAILURE(modalrt_display_reconstruct(snapshot, 0, info.display_vertex_count + 1, 0, surface),
                 MODALRT_ERROR_INVALID_ARGUMENT, "modalrt_display_reconstruct");
  EXPECT_FAILURE(modalrt_display_reconstruct_f64(snapshot, 0, 1, 1u << 9, compliance), MODALRT_ERROR_INVALID_ARGUMENT,
                 "modalrt_display_reconstruct_f64");
  CHECK(modalrt_display_reconstruct(snapshot, 0, 1, MODALRT_DISPLAY_POSITIONS, surface) == MODALRT_OK);

  modalrt_snapshot_destroy(snapshot);
  modalrt_kernel_destroy(kernel);
  modalrt_basis_destroy(basis);
  /* Everything returned to the hooks that gave it; then the default again. */
  printf("  allocator hooks: %ld allocations, %ld frees, %lu bytes outstanding\n", hook_allocations, hook_frees,
         (unsigned long)hook_bytes);
  CHECK(hook_allocations > 0 && hook_allocations == hook_frees && hook_bytes == 0);
  CHECK(modalrt_set_allocator(NULL) == MODALRT_OK);
  printf("test_c_api: %s\n", failures == 0 ? "all checks passed" : "FAILED");
  return failures == 0 ? 0 : 1;
}
