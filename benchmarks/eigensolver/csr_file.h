// Reads the binary CSR matrices modal-precompute writes with 'Output/Export matrices' (<space>_K.csr,
// <space>_M.csr; format: benchmarks/eigensolver/README.md). Used by the SLEPc peer and the static
// correction benchmark.
#pragma once

#include <cstdint>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace modal_haptics_bench
{
  struct Csr
  {
    std::int64_t              n = 0, nnz = 0;
    std::vector<std::int64_t> row_start;
    std::vector<std::int32_t> columns;
    std::vector<double>       values;
  };

  inline Csr read_csr(const std::string &name)
  {
    std::ifstream in(name, std::ios::binary);
    if (!in)
      throw std::runtime_error("cannot read " + name);
    Csr m;
    in.read(reinterpret_cast<char *>(&m.n), 8);
    in.read(reinterpret_cast<char *>(&m.nnz), 8);
    if (!in || m.n < 0 || m.nnz < 0)
      throw std::runtime_error(name + " is not a CSR matrix file");
    m.row_start.resize(m.n + 1);
    m.columns.resize(m.nnz);
    m.values.resize(m.nnz);
    in.read(reinterpret_cast<char *>(m.row_start.data()), 8 * (m.n + 1));
    in.read(reinterpret_cast<char *>(m.columns.data()), 4 * m.nnz);
    in.read(reinterpret_cast<char *>(m.values.data()), 8 * m.nnz);
    if (!in)
      throw std::runtime_error(name + " is truncated");
    return m;
  }
} // namespace modal_haptics_bench
