// The Fortran BLAS and LAPACK routines the precompute calls directly (column-major, arguments by
// pointer; OpenBLAS, or whatever Debian's alternatives pick): deal.II's lapack_templates.h has no
// TRSM or TRMM, and the supernodal solves and factorization stay free of deal.II headers. Also the
// running OpenBLAS' thread count (set_openblas_threads, BlasThreads; defined in factorization.cc).
#pragma once

extern "C"
{
  void dgemm_(const char *, const char *, const int *, const int *, const int *, const double *, const double *,
              const int *, const double *, const int *, const double *, double *, const int *);
  void dgemv_(const char *, const int *, const int *, const double *, const double *, const int *, const double *,
              const int *, const double *, double *, const int *);
  void dsyev_(const char *, const char *, const int *, double *, const int *, double *, double *, const int *, int *);
  void dpotrf_(const char *, const int *, double *, const int *, int *);
  void dsyrk_(const char *, const char *, const int *, const int *, const double *, const double *, const int *,
              const double *, double *, const int *);
  void dpotrs_(const char *, const int *, const int *, const double *, const int *, double *, const int *, int *);
  void dtrmm_(const char *, const char *, const char *, const char *, const int *, const int *, const double *,
              const double *, const int *, double *, const int *);
  void dtrsm_(const char *, const char *, const char *, const char *, const int *, const int *, const double *,
              const double *, const int *, double *, const int *);
}

namespace modal_haptics
{
  // Sets the running OpenBLAS' thread count; returns the previous one (0: the BLAS is not OpenBLAS).
  int set_openblas_threads(int threads);

  // OpenBLAS' thread count, set for a scope and restored after it (no-op with another BLAS: the
  // functions are looked up at run time; the system BLAS is whatever Debian's alternatives pick).
  // The triangular solves set one: their threads are their own (supernodal_solve.h), and BLAS
  // threads inside a supernode's small block only add synchronization (a 4-column solve is slower on
  // 2 BLAS threads than on 1); so do the factorization's subtrees
  // (supernodal_cholesky.h). The top of its tree and the Krylov basis' GEMMs keep every thread.
  class BlasThreads
  {
  public:
    explicit BlasThreads(int threads);
    ~BlasThreads();
    BlasThreads(const BlasThreads &) = delete;
    BlasThreads &operator=(const BlasThreads &) = delete;

  private:
    const int previous;
  };
} // namespace modal_haptics
