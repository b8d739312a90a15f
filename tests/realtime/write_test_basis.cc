// Writes the lattice cantilever (synthetic_scene.cc) to a .mrt file, for the C tests that cannot
// build it themselves (test_c_api, the C-only consumer) and for trying modal-rt on:
//   write_test_basis FILE.mrt [--validity]     --validity: with the made-up validity map (VALIDITY_FORCE)
#include "test_support.h"

#include <cstring>

int main(int argc, char **argv)
{
  const bool validity = argc == 3 && std::strcmp(argv[2], "--validity") == 0;
  if (argc != 2 && !validity)
    {
      std::fprintf(stderr, "usage: write_test_basis FILE.mrt [--validity]\n");
      return 2;
    }
  modalrt::LatticeOptions options;
  options.validity_force = validity;
  return modalrt::write_basis_file(argv[1], modalrt::make_lattice_cantilever(options)) ? 0 : 1;
}
