// Where the bytes of a .mrt basis come from (byte_source.h).
#include "byte_source.h"

#include "error.h"

#include <cerrno>
#include <cstring>

#include <modalrt/modalrt.h>

using namespace modalrt;

FileSource::FileSource(const std::string &path)
  : file_(std::fopen(path.c_str(), "rb"))
{
  if (!file_)
    fail(MODALRT_ERROR_IO, cat("cannot open basis file '", path, "': ", std::strerror(errno)));
  if (!seek(0, SEEK_END))
    fail(MODALRT_ERROR_IO, cat("cannot seek in basis file '", path, "'"));
  size_ = tell();
}

FileSource::~FileSource() { std::fclose(file_); }

bool FileSource::read(std::uint64_t offset, void *out, std::size_t n)
{
  return seek(offset, SEEK_SET) && std::fread(out, 1, n, file_) == n;
}

bool FileSource::seek(std::uint64_t offset, int whence)
{
#if defined(_WIN32)
  return _fseeki64(file_, static_cast<long long>(offset), whence) == 0;
#else
  return fseeko(file_, static_cast<off_t>(offset), whence) == 0;
#endif
}

std::uint64_t FileSource::tell()
{
#if defined(_WIN32)
  return static_cast<std::uint64_t>(_ftelli64(file_));
#else
  return static_cast<std::uint64_t>(ftello(file_));
#endif
}

bool MemorySource::read(std::uint64_t offset, void *out, std::size_t n)
{
  if (offset > size_ || n > size_ - offset)
    return false;
  std::memcpy(out, bytes_ + offset, n);
  return true;
}
