// The rigid-body motions a part's supports leave free (supports.h): the null space of the held
// directions' action on the six rigid motions, and how to name it.
#include "scene/supports.h"

#include <deal.II/base/mpi.h>
#include <deal.II/lac/full_matrix.h>
#include <deal.II/lac/lapack_full_matrix.h>
#include <deal.II/lac/vector.h>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

namespace modal_haptics
{
  using namespace dealii;

  // ---- Free motions ----------------------------------------------------------------------------
  namespace
  {
    // The six rigid motions at offset x from the centre, rotations scaled by the length.
    std::array<Tensor<1, 3>, 6> scaled_rigid_motions(const Tensor<1, 3> &x, const double length)
    {
      std::array<Tensor<1, 3>, 6> motions;
      for (unsigned int k = 0; k < 3; ++k)
        {
          motions[k][k] = 1.;
          Tensor<1, 3> axis;
          axis[k]          = 1.;
          motions[3 + k] = cross_product_3d(axis, x) / length;
        }
      return motions;
    }
  } // namespace

  Tensor<1, 3> FreeMotions::displacement(const unsigned int m, const Point<3> &x) const
  {
    const auto   rigid = scaled_rigid_motions(x - centre, length_scale);
    Tensor<1, 3> u;
    for (unsigned int k = 0; k < 6; ++k)
      u += motions[m][k] * rigid[k];
    return u;
  }

  // The coordinate motions the free span holds are named; a free motion beyond them is described as
  // a rotation about an axis through a point when it is one (its translation normal to its rotation).
  std::string FreeMotions::describe() const
  {
    static const char *const names[6] = {"translation along x", "translation along y", "translation along z",
                                         "rotation about x",    "rotation about y",    "rotation about z"};
    std::vector<std::string> parts;
    for (unsigned int k = 0; k < 6; ++k)
      {
        double in_span = 0.; // |P e_k|^2, P the projection onto the free span
        for (const auto &m : motions)
          in_span += m[k] * m[k];
        if (in_span > 1. - 1e-9)
          parts.push_back(names[k]);
      }
    const std::size_t unnamed = motions.size() - std::min(parts.size(), motions.size());
    if (unnamed == 1 && motions.size() == 1)
      {
        const auto        &c = motions[0];
        const Tensor<1, 3> t({c[0], c[1], c[2]});
        const Tensor<1, 3> w = Tensor<1, 3>({c[3], c[4], c[5]}) / length_scale;
        std::ostringstream out;
        out << std::setprecision(4);
        if (w.norm() > 0. && std::abs(t * w) <= 1e-9 * t.norm() * w.norm() + 1e-300)
          {
            const Point<3> through = centre + cross_product_3d(w, t) / w.norm_square();
            const Tensor<1, 3> axis = w / w.norm();
            out << "rotation about the axis (" << axis[0] << ", " << axis[1] << ", " << axis[2] << ") through ("
                << through[0] << ", " << through[1] << ", " << through[2] << ") m";
          }
        else
          out << "a screw motion (translation (" << t[0] << ", " << t[1] << ", " << t[2] << "), rotation (" << w[0]
              << ", " << w[1] << ", " << w[2] << ") per m)";
        parts.push_back(out.str());
      }
    else if (unnamed > 0)
      parts.push_back(std::to_string(unnamed) + " combination" + (unnamed > 1 ? "s" : "") +
                      " of translations and rotations");
    std::string text;
    for (const auto &part : parts)
      text += (text.empty() ? "" : ", ") + part;
    return text;
  }

  // The null space of G = sum over held directions d at x of g g^T, g_k = d . R_k(x): the rigid
  // motions R that move no held direction. Eigenvalues of G below 1e-10 of its largest are zero (a
  // held direction moves a restrained motion by at least the part's size times the rounding).
  FreeMotions ResolvedSupports::free_motions(const Point<3> &centre, const MPI_Comm comm) const
  {
    FreeMotions free;
    free.centre       = centre;
    free.length_scale = part_diagonal > 0. ? part_diagonal : 1.;
    FullMatrix<double> G(6, 6);
    for (const auto &[x, d] : held)
      {
        const auto rigid = scaled_rigid_motions(x - centre, free.length_scale);
        for (unsigned int k = 0; k < 6; ++k)
          for (unsigned int l = 0; l < 6; ++l)
            G(k, l) += (d * rigid[k]) * (d * rigid[l]);
      }
    Utilities::MPI::sum(G, comm, G);
    if (G.frobenius_norm() == 0.) // nothing held: every motion, about the centre
      {
        for (unsigned int k = 0; k < 6; ++k)
          {
            std::array<double, 6> unit{};
            unit[k] = 1.;
            free.motions.push_back(unit);
          }
        return free;
      }
    LAPACKFullMatrix<double> symmetric(6, 6);
    symmetric = G;
    Vector<double>     eigenvalues;
    FullMatrix<double> eigenvectors;
    symmetric.compute_eigenvalues_symmetric(-1., 2. * G.frobenius_norm() + 1., 0., eigenvalues, eigenvectors);
    const double largest = *std::max_element(eigenvalues.begin(), eigenvalues.end());
    for (unsigned int e = 0; e < eigenvalues.size(); ++e)
      if (eigenvalues[e] <= 1e-10 * largest)
        {
          std::array<double, 6> motion;
          for (unsigned int k = 0; k < 6; ++k)
            motion[k] = std::abs(eigenvectors(k, e)) < 1e-12 ? 0. : eigenvectors(k, e);
          free.motions.push_back(motion);
        }
    return free;
  }

} // namespace modal_haptics
