// The Fortran BLAS and LAPACK routines the precompute calls directly (column-major, arguments by
// pointer; OpenBLAS, or whatever Debian's alternatives pick): deal.II's lapack_templates.h has no
// TRSM or TRMM, and supernodal_solve.cc stays free of deal.II headers.
#pragma once

extern "C"
{
  void dgemm_(const char *, const char *, const int *, const int *, const int *, const double *, const double *,
              const int *, const double *, const int *, const double *, double *, const int *);
  void dsyev_(const char *, const char *, const int *, double *, const int *, double *, double *, const int *, int *);
  void dpotrf_(const char *, const int *, double *, const int *, int *);
  void dpotrs_(const char *, const int *, const int *, const double *, const int *, double *, const int *, int *);
  void dtrmm_(const char *, const char *, const char *, const char *, const int *, const int *, const double *,
              const double *, const int *, double *, const int *);
  void dtrsm_(const char *, const char *, const char *, const char *, const int *, const int *, const double *,
              const double *, const int *, double *, const int *);
}
