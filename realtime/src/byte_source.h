// Where the bytes of a .mrt basis come from (basis_loader.cc reads through it): a file, read at
// 64-bit offsets, or a block of memory.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>

namespace modalrt
{
  class ByteSource
  {
  public:
    virtual ~ByteSource()                                                  = default;
    virtual std::uint64_t size() const                                     = 0;
    virtual bool          read(std::uint64_t offset, void *out, std::size_t n) = 0;
  };

  class FileSource final : public ByteSource
  {
  public:
    // Opens `path`; fails with MODALRT_ERROR_IO (modalrt::Error) if it cannot.
    explicit FileSource(const std::string &path);
    ~FileSource() override;
    FileSource(const FileSource &)            = delete;
    FileSource &operator=(const FileSource &) = delete;

    std::uint64_t size() const override { return size_; }
    bool          read(std::uint64_t offset, void *out, std::size_t n) override;

  private:
    // 64-bit offsets: a basis with r = 1000 on a fine display surface exceeds 2 GB.
    bool          seek(std::uint64_t offset, int whence);
    std::uint64_t tell();

    std::FILE    *file_;
    std::uint64_t size_ = 0;
  };

  class MemorySource final : public ByteSource
  {
  public:
    MemorySource(const void *bytes, std::size_t size)
      : bytes_(static_cast<const unsigned char *>(bytes))
      , size_(size)
    {}
    std::uint64_t size() const override { return size_; }
    bool          read(std::uint64_t offset, void *out, std::size_t n) override;

  private:
    const unsigned char *bytes_;
    std::size_t          size_;
  };
} // namespace modalrt
