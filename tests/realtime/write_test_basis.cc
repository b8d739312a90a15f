// Writes the lattice cantilever (synthetic_scene.cc) to a .mrt file, for the C tests that cannot
// build it themselves (test_c_api, the C-only consumer).   write_test_basis FILE.mrt
#include "test_support.h"

int main(int argc, char **argv)
{
  if (argc != 2)
    {
      std::fprintf(stderr, "usage: write_test_basis FILE.mrt\n");
      return 2;
    }
  return modalrt::write_basis_file(argv[1], modalrt::make_lattice_cantilever()) ? 0 : 1;
}
