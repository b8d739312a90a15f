/* The public header is C: this file is compiled as C99 and linked against the shared library. */
#include <modalrt/modalrt.h>

#include <stdio.h>
#include <string.h>

int main(void)
{
  int                failures = 0;
  modalrt_basis     *basis    = NULL;
  modalrt_kernel_def def      = modalrt_kernel_default_def();
  modalrt_device_def device   = modalrt_device_default_def();
  modalrt_frame_state frame   = modalrt_frame_state_identity();
  int                status   = modalrt_basis_load("/nonexistent.mrt", &basis);

  if (status != MODALRT_ERROR_IO || basis != NULL || strstr(modalrt_last_error_message(), "/nonexistent.mrt") == NULL)
    ++failures;
  if (strcmp(modalrt_status_name(MODALRT_ERROR_CHECKSUM), "MODALRT_ERROR_CHECKSUM") != 0)
    ++failures;
  if (def.time_step != 1e-3 || def.device.max_force != device.max_force || frame.orientation[0] != 1.0)
    ++failures;
  if (modalrt_version() != MODALRT_VERSION_MAJOR * 1000u + MODALRT_VERSION_MINOR)
    ++failures;
  printf("test_c_api: %s\n", failures == 0 ? "all checks passed" : "FAILED");
  return failures == 0 ? 0 : 1;
}
