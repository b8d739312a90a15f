/* A device loop in C11 as a vendor would write it from modalrt.h alone: load, create, press a
 * vertex in impedance for 100 ticks, then lose the device for 600 ticks (the fail-safe rule), then
 * check the outputs. Exit 0 when every check holds. */
#include <modalrt/modalrt.h>

#include <math.h>
#include <stdio.h>

int main(int argc, char **argv)
{
  modalrt_basis *basis = NULL;
  if (argc < 2 || modalrt_basis_load(argv[1], &basis) != MODALRT_OK)
    {
      fprintf(stderr, "consumer: cannot load '%s': %s\n", argc > 1 ? argv[1] : "(no file)", modalrt_last_error_message());
      return 1;
    }
  modalrt_kernel_def def = modalrt_kernel_default_def();
  def.hip_capacity       = 1;
  modalrt_kernel *kernel = NULL;
  if (modalrt_kernel_create(basis, &def, &kernel) != MODALRT_OK)
    {
      fprintf(stderr, "consumer: %s\n", modalrt_last_error_message());
      return 1;
    }
  const double      *x = modalrt_basis_display_vertices(basis);
  modalrt_hip_input  in = {{x[0], x[1], x[2] - 0.001}, {0, 0, 0}, {0, 0, 0}};
  modalrt_hip_output out;
  int                ok = 1;
  modalrt_kernel_contact_begin(kernel, 0, 0);
  for (int n = 0; n < 100; ++n)
    ok = ok && modalrt_kernel_tick_impedance(kernel, &in, 1, &out) == MODALRT_OK;
  const double pressed = sqrt(out.force[0] * out.force[0] + out.force[1] * out.force[1] + out.force[2] * out.force[2]);
  for (int n = 0; n < 600; ++n)
    ok = ok && modalrt_kernel_tick_missing(kernel, 1, &out) == MODALRT_INPUT_REJECTED;
  ok = ok && pressed > 0.0 && out.force[0] == 0.0 && out.force[1] == 0.0 && out.force[2] == 0.0 &&
       (out.flags & MODALRT_HIP_FAIL_SAFE);
  ok = ok && modalrt_kernel_release_hip(kernel, 5) == MODALRT_ERROR_INVALID_ARGUMENT &&
       modalrt_last_error_message()[0] != '\0';
  printf("consumer: modalrt %u, pressed force %.3f N, after 600 missing ticks %.3f N: %s\n", modalrt_version(), pressed,
         out.force[2], ok ? "ok" : "FAILED");
  modalrt_kernel_destroy(kernel);
  modalrt_basis_destroy(basis);
  return ok ? 0 : 1;
}
