#pragma once
// The one file layer of vgeo: whole-file reads with a size cap, positioned reads of an open
// file, and atomic whole-file writes, with one vocabulary of I/O error codes
// (spec/errors.md §Files). Every reader and writer of a vgeo stage or of the `vgeo` tool goes
// through here, so every file the tool writes is atomic and every I/O failure is coded alike.
//
// Atomic write: the bytes go to "<path>.tmp-XXXXXX" in the destination's directory, which is
// fsync'd, renamed over <path>, and then the directory is fsync'd. On any failure before the
// rename the temporary is removed and <path> is left as it was; a failure of the final
// directory fsync leaves the complete new file in place (and is still reported). So a reader
// of <path> sees the old file or the new one, never a partial file — also after a power loss
// once the call has returned. The file replaced stays referenced until the rename is done, and
// its release (on some file systems a synchronous discard of its blocks) overlaps the
// directory's fsync.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace vgeo {

// ---- the I/O error vocabulary (stable codes, spec/errors.md §Files) ----
inline constexpr const char* kErrFileNotFound = "FILE_NOT_FOUND";  // the path does not exist (exit 4)
inline constexpr const char* kErrFileRead = "FILE_READ_ERROR";     // not a regular file, or open/read failed (exit 4)
inline constexpr const char* kErrFileTooLarge = "FILE_TOO_LARGE";  // larger than the reader's cap (exit 3)
inline constexpr const char* kErrFileWrite = "IO_WRITE_FAILED";    // create/write/fsync/rename failed (exit 4)
inline constexpr const char* kErrCreateDir = "IO_CREATE_DIR";      // an output folder cannot be created (exit 4)

// Default cap of read_file: 4 GiB − 1, the largest file any vgeo reader addresses (32-bit
// sizes in GLB and the page format's metadata; tinygltf's length limit).
inline constexpr uint64_t kMaxReadBytes = UINT32_MAX;
// No cap beyond the file itself: for formats whose files may exceed 4 GiB (VGEODAG1, page
// files); the allocation is still the file's own size, a bound derived from the input.
inline constexpr uint64_t kAnyFileSize = UINT64_MAX;

// The whole regular file at `path`. The size is checked against `max_bytes` before anything
// is allocated (FILE_TOO_LARGE); FILE_NOT_FOUND when the path does not exist; FILE_READ_ERROR
// when it is not a regular file, cannot be opened or read, or changed size while being read.
std::vector<uint8_t> read_file(const std::string& path, uint64_t max_bytes = kMaxReadBytes);
// The same in a buffer that is not zero-filled before the read (mesh inputs of tens of MB, where
// the fill cost as much as the read itself). `threads` != 1 (0 = all cores): a file of several
// MiB is read by pieces on that many threads (the same bytes, codes and messages). A file of
// kHugeReadBufferBytes or more is read into a mapping of its own on transparent huge pages
// (allocate_huge_pages, core/process_memory.h), returned to the kernel when freed.
inline constexpr size_t kHugeReadBufferBytes = size_t(256) << 10;
struct FileBytesFree {
  bool huge_pages = false;
  void operator()(uint8_t* p) const;
};
struct FileBytes {
  std::unique_ptr<uint8_t[], FileBytesFree> data;
  size_t size = 0;
};
FileBytes read_file_bytes(const std::string& path, uint64_t max_bytes = kMaxReadBytes, unsigned threads = 1);
// The same, as text (no transcoding).
std::string read_text_file(const std::string& path, uint64_t max_bytes = kMaxReadBytes);

// Reads up to `size` bytes at `offset` of an open file, retrying partial reads and EINTR;
// returns the count read (less than `size` only at end of file), or -1 with errno set.
// Never throws (the page streamer reports read failures as values).
int64_t read_at(int fd, void* dst, size_t size, uint64_t offset);

// A regular file open for positioned reads (metadata-only reads, page streaming). Open
// failures are coded as read_file's; the descriptor is closed by the destructor.
class ReadOnlyFile {
 public:
  explicit ReadOnlyFile(const std::string& path);
  ~ReadOnlyFile();
  ReadOnlyFile(ReadOnlyFile&& other) noexcept;
  ReadOnlyFile& operator=(ReadOnlyFile&&) = delete;
  ReadOnlyFile(const ReadOnlyFile&) = delete;
  ReadOnlyFile& operator=(const ReadOnlyFile&) = delete;

  uint64_t size() const { return size_; }
  int fd() const { return fd_; }
  const std::string& path() const { return path_; }
  // Exactly `size` bytes at `offset` (FILE_READ_ERROR on an I/O error or end of file).
  void read_exact(uint64_t offset, void* dst, size_t size) const;
  // Hands the descriptor to the caller (who then closes it).
  int release();

 private:
  std::string path_;
  int fd_ = -1;
  uint64_t size_ = 0;
};

// Destination of streaming encoders: a file being written, or memory.
struct ByteSink {
  virtual ~ByteSink() = default;
  virtual void write(const void* data, size_t size) = 0;
};

struct MemorySink final : ByteSink {
  std::vector<uint8_t> bytes;
  void write(const void* data, size_t size) override;
};

// The steps of an atomic write, in order; a fault can be injected at each (tests).
enum class WriteStep : uint8_t { kOpen, kWrite, kFsync, kRename, kDirFsync };
const char* write_step_name(WriteStep step);

struct AtomicWriteOptions {
  // Test hook: called before each step; a non-zero return is an errno with which that step
  // fails as if the system call had (the step is not performed).
  std::function<int(WriteStep)> fault;
};

// Atomic whole-file write of `size` bytes (see above). Throws VgeoError IO_WRITE_FAILED
// (kExitIo) naming the failed step.
void write_file_atomic(const std::string& path, const void* bytes, size_t size, const AtomicWriteOptions& options = {});
void write_file_atomic(const std::string& path, std::string_view text, const AtomicWriteOptions& options = {});
// Atomic whole-file write streamed by `encode` (no copy of the whole file in memory). A
// VgeoError thrown by `encode` propagates after the temporary is removed.
void write_file_atomic(const std::string& path, const std::function<void(ByteSink&)>& encode,
                       const AtomicWriteOptions& options = {});

// create_directories with the vocabulary's code (IO_CREATE_DIR, kExitIo); an existing
// directory is fine, an existing non-directory is an error.
void create_output_directory(const std::string& path);

}  // namespace vgeo
