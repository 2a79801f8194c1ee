// The one file layer (lib/vgeo/core/file_io.h): coded read errors, and atomic writes that leave
// the old file or the new one — never a partial file or a temporary — when any step fails:
// injected faults at every step, a real full file system (a small tmpfs in a private mount
// namespace) and a file-size limit (RLIMIT_FSIZE).
#include <gtest/gtest.h>
#include <sched.h>
#include <signal.h>
#include <sys/mount.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "vgeo/core/byte_io.h"
#include "vgeo/core/error.h"
#include "vgeo/core/file_io.h"

namespace vgeo {
namespace {

namespace fs = std::filesystem;

struct ScratchDir {
  fs::path path;
  explicit ScratchDir(const std::string& name)
      : path(fs::temp_directory_path() / ("vgeo_file_io_" + name + "_" + std::to_string(::getpid()))) {
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~ScratchDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
  std::string file(const std::string& name) const { return (path / name).string(); }
  std::vector<std::string> entries() const {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(path)) names.push_back(e.path().filename().string());
    return names;
  }
};

std::string contents(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), {});
}

Error error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const VgeoError& e) {
    return e.error();
  }
  return Error{"(none)", "", "", 0};
}

// A payload larger than the writer's buffer, so it is written in several steps.
std::string big_payload(char fill) { return std::string((size_t(3) << 20) + 12345, fill); }

const WriteStep kAllSteps[] = {WriteStep::kOpen, WriteStep::kWrite, WriteStep::kFsync, WriteStep::kRename,
                               WriteStep::kDirFsync};

TEST(ReadFile, ReadsTheWholeFileAndCodesEveryFailure) {
  ScratchDir dir("read");
  const std::string bytes = std::string("VGEO\0\1\2", 7) + big_payload('x');
  write_file_atomic(dir.file("a.bin"), bytes);
  const std::vector<uint8_t> got = read_file(dir.file("a.bin"));
  EXPECT_EQ(std::string(got.begin(), got.end()), bytes);
  EXPECT_EQ(read_text_file(dir.file("a.bin")), bytes);

  const Error missing = error_of([&] { read_file(dir.file("missing.bin")); });
  EXPECT_EQ(missing.code, kErrFileNotFound);
  EXPECT_EQ(missing.exit_code, kExitIo);
  EXPECT_EQ(missing.where, dir.file("missing.bin"));
  const Error directory = error_of([&] { read_file(dir.path.string()); });
  EXPECT_EQ(directory.code, kErrFileRead);
  EXPECT_EQ(directory.exit_code, kExitIo);
  // The cap is checked before allocating: one byte over is refused, exactly at it accepted.
  const Error too_large = error_of([&] { read_file(dir.file("a.bin"), bytes.size() - 1); });
  EXPECT_EQ(too_large.code, kErrFileTooLarge);
  EXPECT_EQ(too_large.exit_code, kExitBadInput);
  EXPECT_EQ(read_file(dir.file("a.bin"), bytes.size()).size(), bytes.size());
  EXPECT_EQ(error_of([&] { ReadOnlyFile f(dir.file("missing.bin")); }).code, kErrFileNotFound);
  ReadOnlyFile f(dir.file("a.bin"));
  char head[4];
  f.read_exact(0, head, 4);
  EXPECT_EQ(std::string(head, 4), "VGEO");
  EXPECT_EQ(error_of([&] { f.read_exact(bytes.size() - 2, head, 4); }).code, kErrFileRead);
}

// A file of several read pieces (and a last partial one) read on 1, 2, 3 and all threads: the
// same bytes; and the same codes for a missing file and a directory.
TEST(ReadFile, ByPiecesOnThreadsReadsTheSameBytes) {
  ScratchDir dir("pieces");
  std::string bytes((size_t(9) << 20) + 4321, '\0');
  for (size_t i = 0; i < bytes.size(); ++i) bytes[i] = char((i * 2654435761u) >> 13);
  write_file_atomic(dir.file("p.bin"), bytes);
  for (unsigned threads : {1u, 2u, 3u, 0u}) {
    const FileBytes got = read_file_bytes(dir.file("p.bin"), kMaxReadBytes, threads);
    ASSERT_EQ(got.size, bytes.size()) << threads;
    EXPECT_EQ(std::memcmp(got.data.get(), bytes.data(), bytes.size()), 0) << threads;
    EXPECT_EQ(error_of([&] { read_file_bytes(dir.file("missing.bin"), kMaxReadBytes, threads); }).code, kErrFileNotFound);
    EXPECT_EQ(error_of([&] { read_file_bytes(dir.path.string(), kMaxReadBytes, threads); }).code, kErrFileRead);
  }
}

// Every step of the writer failing, with and without a previous file: before the rename the
// previous file (or no file) remains; after it the complete new file; never a temporary.
TEST(AtomicWrite, AFaultAtEveryStepLeavesTheOldFileOrTheNewOne) {
  const std::string old_bytes = "old contents\n", new_bytes = big_payload('n');
  for (bool had_file : {true, false})
    for (WriteStep step : kAllSteps) {
      SCOPED_TRACE(std::string(write_step_name(step)) + (had_file ? ", previous file" : ", no previous file"));
      ScratchDir dir("fault");
      const std::string path = dir.file("out.bin");
      if (had_file) write_file_atomic(path, old_bytes);
      AtomicWriteOptions o;
      int calls = 0;
      o.fault = [&](WriteStep s) {
        ++calls;
        return s == step ? EIO : 0;
      };
      const Error e = error_of([&] { write_file_atomic(path, new_bytes, o); });
      EXPECT_EQ(e.code, kErrFileWrite);
      EXPECT_EQ(e.exit_code, kExitIo);
      EXPECT_EQ(e.where, path);
      EXPECT_NE(e.what.find(write_step_name(step)), std::string::npos) << e.what;
      EXPECT_NE(e.what.find(std::strerror(EIO)), std::string::npos) << e.what;
      EXPECT_GT(calls, 0);
      if (step == WriteStep::kDirFsync) {
        EXPECT_EQ(contents(path), new_bytes);  // renamed already: the complete new file
      } else if (had_file) {
        EXPECT_EQ(contents(path), old_bytes);
      } else {
        EXPECT_FALSE(fs::exists(path));
      }
      const std::vector<std::string> left = dir.entries();
      EXPECT_EQ(left.size(), (had_file || step == WriteStep::kDirFsync) ? 1u : 0u);
      for (const std::string& name : left) EXPECT_EQ(name, "out.bin");
    }
}

// Replacing a file: the old file is held across the rename and released beside the directory's
// fsync (file_io.cpp). A reader that opened the old file keeps reading its bytes, the path has
// the new ones, nothing else is left; a symbolic link at the path is replaced itself, and the
// file it pointed at is unchanged.
TEST(AtomicWrite, ReplacingAFileOrALinkKeepsTheOldInodeIntactForItsReaders) {
  ScratchDir dir("replace");
  const std::string path = dir.file("out.bin"), old_bytes = big_payload('o'), new_bytes = "new\n";
  write_file_atomic(path, old_bytes);
  std::FILE* reader = std::fopen(path.c_str(), "rb");
  ASSERT_NE(reader, nullptr);
  write_file_atomic(path, new_bytes);
  std::string seen(old_bytes.size(), '\0');
  EXPECT_EQ(std::fread(seen.data(), 1, seen.size(), reader), old_bytes.size());
  std::fclose(reader);
  EXPECT_EQ(seen, old_bytes);
  EXPECT_EQ(contents(path), new_bytes);
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"out.bin"});

  const std::string target = dir.file("target.bin"), link = dir.file("link.bin");
  write_file_atomic(target, "target\n");
  fs::create_symlink(target, link);
  write_file_atomic(link, new_bytes);
  EXPECT_FALSE(fs::is_symlink(link));
  EXPECT_EQ(contents(link), new_bytes);
  EXPECT_EQ(contents(target), "target\n");
}

// A fault in the middle of a streamed file (its third buffer write), and an encoder that
// throws part way: the previous file stays, the temporary is removed.
TEST(AtomicWrite, AFailureMidStreamKeepsThePreviousFile) {
  ScratchDir dir("midstream");
  const std::string path = dir.file("out.bin");
  write_file_atomic(path, "previous");
  const std::vector<uint8_t> chunk(size_t(700) << 10, 7);  // < the buffer: several buffered flushes
  AtomicWriteOptions o;
  int writes = 0;
  o.fault = [&](WriteStep s) { return s == WriteStep::kWrite && ++writes == 3 ? ENOSPC : 0; };
  auto encode = [&](ByteSink& sink) {
    for (int i = 0; i < 8; ++i) sink.write(chunk.data(), chunk.size());
  };
  const Error e = error_of([&] { write_file_atomic(path, encode, o); });
  EXPECT_EQ(e.code, kErrFileWrite);
  EXPECT_EQ(writes, 3);
  EXPECT_EQ(contents(path), "previous");
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"out.bin"});

  const Error thrown = error_of([&] {
    write_file_atomic(path, [&](ByteSink& sink) {
      sink.write(chunk.data(), chunk.size());
      fail("TEST_ENCODER", "<encoder>", "gave up");
    });
  });
  EXPECT_EQ(thrown.code, "TEST_ENCODER");
  EXPECT_EQ(contents(path), "previous");
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"out.bin"});
}

TEST(AtomicWrite, StreamedAndWholeWritesProduceTheSameBytes) {
  ScratchDir dir("bytes");
  std::vector<uint8_t> expected;
  ByteWriter w;
  for (uint32_t i = 0; i < 300000; ++i) w.u32(i * 2654435761u);
  w.f32(-0.0f);
  w.u64(0x0123456789ABCDEFull);
  expected = w.bytes;
  write_file_atomic(dir.file("whole.bin"), expected.data(), expected.size());
  write_file_atomic(dir.file("streamed.bin"), [&](ByteSink& sink) {
    ByteWriter s;
    s.sink = &sink;
    s.raw(expected.data(), 5);                                  // buffered
    s.raw(expected.data() + 5, ByteWriter::kFlushBytes + 3);    // straight to the sink
    s.raw(expected.data() + 5 + ByteWriter::kFlushBytes + 3, expected.size() - 5 - ByteWriter::kFlushBytes - 3);
    s.flush();
  });
  EXPECT_EQ(read_file(dir.file("whole.bin")), expected);
  EXPECT_EQ(read_file(dir.file("streamed.bin")), expected);
  EXPECT_EQ(fs::status(dir.file("whole.bin")).permissions() & fs::perms::all,
            fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read | fs::perms::others_read);
  // Little-endian whatever the host, and the checked reader gives the fields back.
  const std::string where = dir.path.string();  // outlives the reader, which keeps a pointer
  ByteReader r(expected.data(), expected.size(), where, "TEST_TRUNCATED", "test data");
  EXPECT_EQ(r.u32(), 0u);
  EXPECT_EQ(r.u32(), 2654435761u);
  EXPECT_EQ(expected[4], 0xB1);
  r.pos = expected.size() - 12;
  EXPECT_TRUE(std::signbit(r.f32()));
  EXPECT_EQ(load_le64(r.take(8)), 0x0123456789ABCDEFull);
  const Error e = error_of([&] { r.u8(); });
  EXPECT_EQ(e.code, "TEST_TRUNCATED");
  EXPECT_EQ(e.what, "test data ends inside a field");
}

// ---- real failures of the file system, in a child process ----

// Runs `body` in a forked child; returns its exit status and what it wrote to the pipe
// (the reason, when it failed).
int run_in_child(const std::function<std::string()>& body, std::string* message) {
  int fds[2];
  if (::pipe(fds) != 0) {
    *message = "pipe failed";
    return -1;
  }
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::close(fds[0]);
    std::string failure;
    try {
      failure = body();
    } catch (const std::exception& e) {
      failure = std::string("unexpected exception: ") + e.what();
    }
    if (!failure.empty()) (void)!::write(fds[1], failure.data(), failure.size());
    ::_exit(failure.empty() ? 0 : 1);
  }
  ::close(fds[1]);
  char buf[512];
  ssize_t n;
  while ((n = ::read(fds[0], buf, sizeof buf)) > 0) message->append(buf, size_t(n));
  ::close(fds[0]);
  int status = 0;
  ::waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

// The full-device scenario, shared by both ways of making a device full: a small previous
// file is written, a big one fails with a coded error leaving the previous file whole and no
// temporary, then a small one succeeds.
std::string fill_the_device(const std::string& dir, int expected_errno) {
  const std::string path = dir + "/out.bin";
  write_file_atomic(path, "previous");
  const Error e = error_of([&] { write_file_atomic(path, big_payload('f')); });
  if (e.code != kErrFileWrite || e.exit_code != kExitIo) return "big write: got " + e.code + " " + e.what;
  if (e.what.find(std::strerror(expected_errno)) == std::string::npos) return "big write: unexpected cause: " + e.what;
  if (contents(path) != "previous") return "the previous file changed";
  size_t entries = 0;
  for (const auto& entry : fs::directory_iterator(dir)) entries += 1, (void)entry;
  if (entries != 1) return "a temporary file was left behind";
  write_file_atomic(path, "small new");
  if (contents(path) != "small new") return "the small write after the failure did not land";
  return "";
}

bool write_proc_file(const char* path, const std::string& text) {
  std::ofstream f(path);
  f << text;
  return bool(f.flush());
}

// A 256 KiB tmpfs, mounted in a private mount namespace (root: unshare(CLONE_NEWNS); anyone
// else: inside a new user namespace), so nothing outside the child ever sees it. If the
// namespace or the mount cannot be set up the test fails: it never skips.
TEST(AtomicWrite, AFullFileSystemLeavesThePreviousFile) {
  ScratchDir dir("tmpfs");
  const std::string mount_point = dir.file("mnt");
  fs::create_directories(mount_point);
  std::string message;
  const int rc = run_in_child(
      [&]() -> std::string {
        const uid_t uid = ::geteuid();
        const gid_t gid = ::getegid();
        if (uid == 0) {
          if (::unshare(CLONE_NEWNS) != 0) return std::string("unshare(CLONE_NEWNS): ") + std::strerror(errno);
        } else {
          if (::unshare(CLONE_NEWUSER | CLONE_NEWNS) != 0)
            return std::string("unshare(CLONE_NEWUSER | CLONE_NEWNS): ") + std::strerror(errno);
          if (!write_proc_file("/proc/self/setgroups", "deny") ||
              !write_proc_file("/proc/self/uid_map", "0 " + std::to_string(uid) + " 1") ||
              !write_proc_file("/proc/self/gid_map", "0 " + std::to_string(gid) + " 1"))
            return "cannot map the user namespace's ids";
        }
        if (::mount(nullptr, "/", nullptr, MS_REC | MS_PRIVATE, nullptr) != 0)
          return std::string("making / private: ") + std::strerror(errno);
        if (::mount("tmpfs", mount_point.c_str(), "tmpfs", 0, "size=256k") != 0)
          return std::string("mount tmpfs: ") + std::strerror(errno);
        return fill_the_device(mount_point, ENOSPC);
      },
      &message);
  EXPECT_EQ(rc, 0) << message;
}

// The same with the process's file-size limit (EFBIG), which needs no privileges.
TEST(AtomicWrite, AFileSizeLimitLeavesThePreviousFile) {
  ScratchDir dir("fsize");
  std::string message;
  const int rc = run_in_child(
      [&]() -> std::string {
        ::signal(SIGXFSZ, SIG_IGN);  // the write then fails with EFBIG instead of killing us
        const rlimit limit{256 << 10, 256 << 10};
        if (::setrlimit(RLIMIT_FSIZE, &limit) != 0) return std::string("setrlimit: ") + std::strerror(errno);
        return fill_the_device(dir.path.string(), EFBIG);
      },
      &message);
  EXPECT_EQ(rc, 0) << message;
}

TEST(CreateOutputDirectory, CodesAPathThatIsAFile) {
  ScratchDir dir("mkdir");
  create_output_directory(dir.file("a/b"));
  EXPECT_TRUE(fs::is_directory(dir.file("a/b")));
  create_output_directory(dir.file("a/b"));  // existing: fine
  write_file_atomic(dir.file("f"), "x");
  const Error e = error_of([&] { create_output_directory(dir.file("f")); });
  EXPECT_EQ(e.code, kErrCreateDir);
  EXPECT_EQ(e.exit_code, kExitIo);
}

}  // namespace
}  // namespace vgeo
