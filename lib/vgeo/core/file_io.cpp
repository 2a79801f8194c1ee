// The one file layer (see file_io.h): POSIX calls directly, so every step of an atomic write
// can fail on its own, be reported with its name, and be faulted by tests.
#include "vgeo/core/file_io.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <thread>

#include "vgeo/core/error.h"
#include "vgeo/core/process_memory.h"
#include "vgeo/core/thread_pool.h"

namespace vgeo {
namespace {

// Write buffer of the atomic writer: many small writes become large sequential ones.
constexpr size_t kWriteBufferBytes = size_t(1) << 20;
// Writes at least this large go to the file straight from the caller's memory: one system call
// per 64 KiB costs nothing next to the copy, and the buffer's pages are never touched by the
// chunks a ByteWriter hands over (core/byte_io.h), only by small writes.
constexpr size_t kDirectWriteBytes = size_t(64) << 10;
// Permissions of a written file: the usual ones of a new file (mkstemp creates 0600).
constexpr mode_t kNewFileMode = 0644;

std::string errno_text(int err) { return std::strerror(err); }

[[noreturn]] void read_fail(const std::string& path, const std::string& what, int err) {
  fail(err == ENOENT ? kErrFileNotFound : kErrFileRead, path, err ? what + ": " + errno_text(err) : what, kExitIo);
}

// Opens `path` for reading and checks it is a regular file; returns the descriptor and size.
int open_regular_file(const std::string& path, uint64_t* size) {
  int fd;
  do fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  while (fd < 0 && errno == EINTR);
  if (fd < 0) read_fail(path, errno == ENOENT ? "no such file" : "cannot open", errno);
  struct stat st {};
  if (::fstat(fd, &st) != 0) {
    const int err = errno;
    ::close(fd);
    read_fail(path, "cannot stat", err);
  }
  if (!S_ISREG(st.st_mode)) {
    ::close(fd);
    read_fail(path, "not a regular file", 0);
  }
  *size = uint64_t(st.st_size);
  return fd;
}

// Pieces of a whole-file read on several threads: a piece's read (a kernel copy of its page-cache
// pages and the first touch of its buffer pages, ~1 ms per 4 MiB) is far above the cost of
// handing it out, and a mesh input of tens of MB still gives every thread of a small pool
// several pieces. Files under two pieces are read in one call.
constexpr size_t kParallelReadPieceBytes = size_t(4) << 20;

// Reads `size` bytes at offset 0 into dst: in one read_at, or by pieces on a pool of `threads`
// threads (0 = all cores) when threads != 1 and the file has at least two pieces. Returns the
// count read up to the first short piece (so a file that shrank reads short either way), or -1
// with errno of the first failed piece (in file order).
int64_t read_prefix(int fd, uint8_t* dst, size_t size, unsigned threads) {
  const size_t pieces = (size + kParallelReadPieceBytes - 1) / kParallelReadPieceBytes;
  if (threads == 1 || pieces < 2) return read_at(fd, dst, size, 0);
  std::vector<int64_t> got(pieces);
  std::vector<int> error(pieces, 0);
  ThreadPool pool(threads);
  pool.parallel_for(pieces, [&](size_t i) {
    const size_t offset = i * kParallelReadPieceBytes, length = std::min(kParallelReadPieceBytes, size - offset);
    got[i] = read_at(fd, dst + offset, length, offset);
    if (got[i] < 0) error[i] = errno;
  });
  int64_t total = 0;
  for (size_t i = 0; i < pieces; ++i) {
    if (got[i] < 0) {
      errno = error[i];
      return -1;
    }
    total += got[i];
    if (size_t(got[i]) != std::min(kParallelReadPieceBytes, size - i * kParallelReadPieceBytes)) break;
  }
  return total;
}

// Reads the whole file into the buffer `allocate(size)` returns (the size as the file system
// reports it, capped above before anything is allocated); `threads` as read_prefix.
template <class Allocate>
void read_whole(const std::string& path, uint64_t max_bytes, Allocate&& allocate, unsigned threads = 1) {
  ReadOnlyFile file(path);
  if (file.size() > max_bytes)
    fail(kErrFileTooLarge, path,
         "file of " + std::to_string(file.size()) + " bytes exceeds the limit of " + std::to_string(max_bytes), kExitBadInput);
  const size_t size = size_t(file.size());
  uint8_t* dst = allocate(size);
  const int64_t got = read_prefix(file.fd(), dst, size, threads);
  if (got < 0) read_fail(path, "read failed", errno);
  uint8_t extra;
  if (uint64_t(got) != size || read_at(file.fd(), &extra, 1, size) != 0)
    read_fail(path, "the file changed size while being read", 0);
}

// Temporary file next to `path`: written through a buffer, then committed (fsync, rename,
// directory fsync). Removed by the destructor unless renamed into place.
class AtomicFile final : public ByteSink {
 public:
  AtomicFile(const std::string& path, const AtomicWriteOptions& options)
      : path_(path), temp_(path + ".tmp-XXXXXX"), options_(options) {
    step(WriteStep::kOpen);
    fd_ = ::mkstemp(temp_.data());
    if (fd_ < 0) step_fail(WriteStep::kOpen, errno);
    created_ = true;
    ::fchmod(fd_, kNewFileMode);
    buffer_.reserve(kWriteBufferBytes);
  }
  ~AtomicFile() override {
    if (fd_ >= 0) ::close(fd_);
    if (created_ && !renamed_) ::unlink(temp_.c_str());
  }
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  void write(const void* data, size_t size) override {
    if (buffer_.size() + size > kWriteBufferBytes || size >= kDirectWriteBytes) flush();
    if (size >= kDirectWriteBytes) {
      write_fd(data, size);
      return;
    }
    const auto* p = static_cast<const uint8_t*>(data);
    buffer_.insert(buffer_.end(), p, p + size);
  }

  void commit() {
    flush();
    step(WriteStep::kFsync);
    if (::fsync(fd_) != 0) step_fail(WriteStep::kFsync, errno);
    const int rc = ::close(fd_);
    fd_ = -1;
    // close reports deferred write errors (e.g. NFS, quota): the data may not be there.
    if (rc != 0 && errno != EINTR) step_fail(WriteStep::kWrite, errno);
    step(WriteStep::kRename);
    // The file being replaced, if any, stays referenced across the rename (O_PATH: no access
    // needed, no blocking on a FIFO; O_NOFOLLOW: a link is what the rename replaces), so the
    // rename only swaps names. Dropping the old inode, on ext4 mounted with `discard` a
    // synchronous discard of its blocks (14-16 ms for a 32 MB file, ~1.5 ms for 2.4 MB,
    // docs/acceptance/issue23_io40.md), then runs on a helper thread beside the directory's
    // fsync, and is joined before this returns or throws.
    const int replaced = ::open(path_.c_str(), O_PATH | O_NOFOLLOW | O_CLOEXEC);
    if (::rename(temp_.c_str(), path_.c_str()) != 0) {
      const int err = errno;
      if (replaced >= 0) ::close(replaced);
      step_fail(WriteStep::kRename, err);
    }
    renamed_ = true;
    std::jthread release_replaced;
    if (replaced >= 0) release_replaced = std::jthread([replaced] { ::close(replaced); });
    // The rename is durable only once the directory entry is: fsync the directory.
    step(WriteStep::kDirFsync);
    const std::filesystem::path dir = std::filesystem::path(path_).parent_path();
    const std::string dir_name = dir.empty() ? "." : dir.string();
    const int dfd = ::open(dir_name.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (dfd < 0) step_fail(WriteStep::kDirFsync, errno);
    const int drc = ::fsync(dfd);
    const int derr = errno;
    ::close(dfd);
    // EINVAL: the file system cannot sync directories (allowed by POSIX); nothing to wait for.
    if (drc != 0 && derr != EINVAL) step_fail(WriteStep::kDirFsync, derr);
  }

 private:
  void flush() {
    if (buffer_.empty()) return;
    write_fd(buffer_.data(), buffer_.size());
    buffer_.clear();
  }
  void write_fd(const void* data, size_t size) {
    step(WriteStep::kWrite);
    const auto* p = static_cast<const uint8_t*>(data);
    while (size > 0) {
      const ssize_t n = ::write(fd_, p, size);
      if (n < 0 && errno == EINTR) continue;
      if (n < 0) step_fail(WriteStep::kWrite, errno);
      if (n == 0) step_fail(WriteStep::kWrite, ENOSPC);  // no progress: treat as a full device
      p += n;
      size -= size_t(n);
    }
  }
  void step(WriteStep s) {
    if (!options_.fault) return;
    if (const int err = options_.fault(s)) step_fail(s, err);
  }
  [[noreturn]] void step_fail(WriteStep s, int err) {
    const std::string what = std::string(write_step_name(s)) + " failed: " + errno_text(err);
    fail(kErrFileWrite, path_, renamed_ ? what + " (the new file is in place)" : what + " (the previous file is unchanged)",
         kExitIo);
  }

  std::string path_, temp_;
  const AtomicWriteOptions& options_;
  std::vector<uint8_t> buffer_;
  int fd_ = -1;
  bool created_ = false, renamed_ = false;
};

}  // namespace

int64_t read_at(int fd, void* dst, size_t size, uint64_t offset) {
  size_t got = 0;
  while (got < size) {
    const ssize_t n = ::pread(fd, static_cast<uint8_t*>(dst) + got, size - got, off_t(offset + got));
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return -1;
    if (n == 0) break;
    got += size_t(n);
  }
  return int64_t(got);
}

std::vector<uint8_t> read_file(const std::string& path, uint64_t max_bytes) {
  std::vector<uint8_t> bytes;
  read_whole(path, max_bytes, [&](size_t size) {
    bytes.resize(size);
    return bytes.data();
  });
  return bytes;
}

void FileBytesFree::operator()(uint8_t* p) const {
  if (huge_pages) free_huge_pages(p);
  else delete[] p;
}

// Where the read goes (kHugeReadBufferBytes): a read into fresh memory faults in each of its
// pages inside the kernel's copy, ~12 us per 4 KiB on the virtual machine of
// docs/acceptance/issue23_write.md, where one 2 MiB huge page costs ~0.3-0.8 ms: from ~64 KiB
// of file per huge page on, the huge pages are cheaper, and 256 KiB keeps that sure while the
// rounding up to whole huge pages (at most 2 MiB more, for the import only) stays small next to
// a mesh of that size's build. A heap buffer only got huge pages where it happened to cover an
// aligned 2 MiB stretch (bunny00's 2.6 MB file: one in two runs). bunny00 .vgeodag: -2%
// task-clock (docs/acceptance/issue23_leaf38.md). Smaller files stay in the heap.
FileBytes read_file_bytes(const std::string& path, uint64_t max_bytes, unsigned threads) {
  FileBytes bytes;
  read_whole(
      path, max_bytes,
      [&](size_t size) {
        uint8_t* huge = size >= kHugeReadBufferBytes ? static_cast<uint8_t*>(allocate_huge_pages(size)) : nullptr;
        if (huge) bytes.data = std::unique_ptr<uint8_t[], FileBytesFree>(huge, FileBytesFree{true});
        else bytes.data.reset(new uint8_t[size]);  // default-initialised: the read fills it
        bytes.size = size;
        return bytes.data.get();
      },
      threads);
  return bytes;
}

std::string read_text_file(const std::string& path, uint64_t max_bytes) {
  std::string text;
  read_whole(path, max_bytes, [&](size_t size) {
    text.resize(size);
    return reinterpret_cast<uint8_t*>(text.data());
  });
  return text;
}

ReadOnlyFile::ReadOnlyFile(const std::string& path) : path_(path) { fd_ = open_regular_file(path, &size_); }

ReadOnlyFile::~ReadOnlyFile() {
  if (fd_ >= 0) ::close(fd_);
}

ReadOnlyFile::ReadOnlyFile(ReadOnlyFile&& other) noexcept
    : path_(std::move(other.path_)), fd_(other.fd_), size_(other.size_) {
  other.fd_ = -1;
}

void ReadOnlyFile::read_exact(uint64_t offset, void* dst, size_t size) const {
  const int64_t got = read_at(fd_, dst, size, offset);
  if (got < 0) read_fail(path_, "read failed", errno);
  if (uint64_t(got) != size) read_fail(path_, "unexpected end of file", 0);
}

int ReadOnlyFile::release() {
  const int fd = fd_;
  fd_ = -1;
  return fd;
}

void MemorySink::write(const void* data, size_t size) {
  const auto* p = static_cast<const uint8_t*>(data);
  bytes.insert(bytes.end(), p, p + size);
}

const char* write_step_name(WriteStep step) {
  switch (step) {
    case WriteStep::kOpen: return "creating the temporary file";
    case WriteStep::kWrite: return "writing";
    case WriteStep::kFsync: return "fsync";
    case WriteStep::kRename: return "renaming the temporary file into place";
    case WriteStep::kDirFsync: return "fsync of the directory";
  }
  return "?";
}

void write_file_atomic(const std::string& path, const void* bytes, size_t size, const AtomicWriteOptions& options) {
  write_file_atomic(path, [&](ByteSink& s) { s.write(bytes, size); }, options);
}

void write_file_atomic(const std::string& path, std::string_view text, const AtomicWriteOptions& options) {
  write_file_atomic(path, text.data(), text.size(), options);
}

void write_file_atomic(const std::string& path, const std::function<void(ByteSink&)>& encode,
                       const AtomicWriteOptions& options) {
  AtomicFile file(path, options);
  encode(file);
  file.commit();
}

void create_output_directory(const std::string& path) {
  std::error_code ec;
  std::filesystem::create_directories(path, ec);
  if (ec || !std::filesystem::is_directory(path, ec))
    fail(kErrCreateDir, path, "cannot create the output directory" + (ec ? ": " + ec.message() : std::string()), kExitIo);
}

}  // namespace vgeo
