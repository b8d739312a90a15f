// Writes a synthetic basis for the view's browser test and benchmark:
//   make_view_fixture lattice FILE [FACTOR]  the lattice cantilever (exact modes, candidates with
//                                            static corrections, cross compliance, float64 modes, the
//                                            felt-stiffness map at the candidates, 0 at the clamped edge,
//                                            the made-up validity map of synthetic_scene.h at the candidates);
//                                            FACTOR scales its felt-stiffness map (a design B to compare)
//   make_view_fixture plate FILE NX NY R     the analytic plate with NX x NY display vertices and R
//                                            modes per space (float32 modes), for the 100k benchmark
#include "synthetic_scene.h"

#include <cstdio>
#include <cstdlib>
#include <string>

int main(int argc, char **argv)
{
  const std::string kind = argc > 2 ? argv[1] : "";
  std::string       error;
  bool              ok = false;
  if (kind == "lattice" && (argc == 3 || argc == 4))
    {
      modalrt::LatticeOptions o;
      o.nx           = 13;
      o.ny           = 4;
      o.patch_radius = 0.02; // [m] a patch of a few vertices at this spacing (16.7 mm)
      o.felt_stiffness = true;
      o.validity_force = true;
      modalrt::BasisContent content = modalrt::make_lattice_cantilever(o);
      const double          factor  = argc == 4 ? std::atof(argv[3]) : 1.0;
      for (auto &space : content.spaces)
        for (double &k : space.felt_stiffness)
          k *= factor;
      ok = modalrt::write_basis_file(argv[2], content, &error);
    }
  else if (kind == "plate" && argc == 6)
    {
      modalrt::PlateOptions o;
      o.nx    = std::uint32_t(std::atoi(argv[3]));
      o.ny    = std::uint32_t(std::atoi(argv[4]));
      o.modes = std::uint32_t(std::atoi(argv[5]));
      ok      = modalrt::write_basis_file(argv[2], modalrt::make_analytic_plate(o), &error);
    }
  else
    {
      std::fprintf(stderr, "usage: make_view_fixture lattice FILE [FACTOR] | plate FILE NX NY MODES\n");
      return 2;
    }
  if (!ok)
    std::fprintf(stderr, "make_view_fixture: %s\n", error.c_str());
  return ok ? 0 : 1;
}
