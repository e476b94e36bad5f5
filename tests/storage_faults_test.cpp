// What `kgd design` and the readers of design files promise when storage fails (docs/RELIABILITY.md):
// a write that fails (a full disk: the file-size limit of the process, or ENOSPC injected by libfiu's
// POSIX preload) stops the job with exit 4 naming the file, the error and the last iteration stored, and
// the file resumes bit for bit; a damaged file is named, not served; one writer per file. The real kgd
// binary and real HDF5 files; the faults are real system errors returned by the kernel or libc.
#include <gtest/gtest.h>

#include <hdf5.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "store/design_file.h"
#include "tests/child_process.h"
#include "tests/kgd_cli.h"

namespace kgd {
namespace {

namespace fs = std::filesystem;
using ::kgd::cli_test::CommandRun;
using ::kgd::cli_test::Kgd;

class StorageFaults : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / "kgd_storage_faults" / ::testing::UnitTest::GetInstance()->current_test_info()->name();
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  std::string Path(const std::string& name) const { return (dir_ / name).string(); }
  fs::path dir_;
};

// A small, quick job: the pull test from all reinforced down to 60 %.
const std::string kJob = "design pull_test_all_cloth --budget 0.6 --er 0.05 --ar-max 0.05";

// A shell command line with kgd's output, as a user's terminal would show it.
CommandRun Shell(const std::string& command) {
  FILE* p = popen((command + " 2>&1").c_str(), "r");
  std::string out;
  std::array<char, 4096> buf;
  while (size_t n = fread(buf.data(), 1, buf.size(), p)) out.append(buf.data(), n);
  const int status = pclose(p);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status), out};
}

void ExpectSameDesigns(const std::string& a_path, const std::string& b_path) {
  const Result<DesignFile> a = ReadDesignFile(a_path), b = ReadDesignFile(b_path);
  ASSERT_TRUE(a.ok()) << a.message();
  ASSERT_TRUE(b.ok()) << b.message();
  ASSERT_EQ(a->iterations.size(), b->iterations.size());
  for (size_t k = 0; k < a->iterations.size(); ++k) {
    EXPECT_EQ(a->iterations[k].design, b->iterations[k].design) << "iteration " << k;
    EXPECT_TRUE(a->iterations[k].positions == b->iterations[k].positions) << "iteration " << k;
    EXPECT_EQ(a->iterations[k].energy_J, b->iterations[k].energy_J) << "iteration " << k;
    EXPECT_EQ(a->iterations[k].density_ratio, b->iterations[k].density_ratio) << "iteration " << k;
  }
}

int StoredIterations(const std::string& path) {
  const Result<DesignFile> f = ReadDesignFile(path, {.arrays = false});
  return f.ok() ? static_cast<int>(f->iterations.size()) : -1;
}

// The design file may grow to `limit` bytes and no further (the process's file-size limit; SIGXFSZ
// ignored, so a write past it fails with EFBIG): the job stops with exit 4, naming the file, the error
// and the iterations stored, never "done". The file, cut short of the end its superblock records, is
// refused by readers with the way to repair it, and `--resume` repairs it and goes on to the
// uninterrupted run's designs bit for bit.
TEST_F(StorageFaults, AFileThatCannotGrowStopsTheJobAndResumesBitForBit) {
  ASSERT_EQ(Kgd(kJob + " --iterations 12 --out " + Path("whole.h5")).exit_code, 0);
  ASSERT_EQ(Kgd(kJob + " --iterations 5 --out " + Path("five.h5")).exit_code, 0);
  const uintmax_t limit = fs::file_size(Path("five.h5")) + 512;
  const CommandRun r = Shell("sh -c \"trap '' XFSZ; exec prlimit --fsize=" + std::to_string(limit) + " " + KGD_BINARY + " " + kJob +
                             " --iterations 12 --out " + Path("full.h5") + "\"");
  EXPECT_EQ(r.exit_code, 4) << r.output;
  EXPECT_NE(r.output.find(Path("full.h5") + ": cannot write iteration"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("File too large (EFBIG)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find(" are stored; once there is room, continue with: kgd design --resume"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("\"event\":\"done\""), std::string::npos) << "a failed write reported as a finished job:\n" << r.output;
  const CommandRun designs = Kgd("designs " + Path("full.h5"));
  if (designs.exit_code != 0) EXPECT_NE(designs.output.find("--resume FILE` repairs"), std::string::npos) << designs.output;
  const CommandRun resumed = Kgd("design --resume " + Path("full.h5") + " --iterations 12");
  ASSERT_EQ(resumed.exit_code, 0) << resumed.output;
  ExpectSameDesigns(Path("whole.h5"), Path("full.h5"));
}

// A real full disk: the job's folder on a small tmpfs (mounting needs root; skipped otherwise). The job
// stops with exit 4 and ENOSPC; the file reads back, intact, to the iteration the message names; once
// the file system is grown, `--resume` continues to the uninterrupted run's designs bit for bit.
TEST_F(StorageFaults, AFullDiskStopsTheJobNamingTheFileAndItResumesBitForBit) {
  ASSERT_EQ(Kgd(kJob + " --iterations 12 --out " + Path("whole.h5")).exit_code, 0);
  ASSERT_EQ(Kgd(kJob + " --iterations 5 --out " + Path("five.h5")).exit_code, 0);
  const std::string disk = Path("disk");
  fs::create_directories(disk);
  // Room for less than the whole job: the disk fills part of the way.
  const uintmax_t size = fs::file_size(Path("whole.h5")) - (64 << 10);
  if (Shell("mount -t tmpfs -o size=" + std::to_string(size) + " kgd-test " + disk).exit_code != 0)
    GTEST_SKIP() << "cannot mount a small tmpfs here (needs root)";
  struct Unmount {
    std::string at;
    ~Unmount() { Shell("umount " + at); }
  } unmount{disk};
  const std::string file = disk + "/full.h5";
  const CommandRun r = Kgd(kJob + " --iterations 12 --out " + file);
  EXPECT_EQ(r.exit_code, 4) << r.output;
  EXPECT_NE(r.output.find(file + ": cannot write iteration"), std::string::npos) << r.output;
  // Met by the system's ENOSPC, or before it by the room kgd keeps free.
  EXPECT_TRUE(r.output.find("No space left on device (ENOSPC)") != std::string::npos || r.output.find("the disk is nearly full (ENOSPC)") != std::string::npos)
      << r.output;
  EXPECT_EQ(r.output.find("\"event\":\"done\""), std::string::npos) << "a failed write reported as a finished job:\n" << r.output;
  const int stored = StoredIterations(file);
  ASSERT_GE(stored, 1) << "the file does not read back: " << Kgd("designs " + file).output;
  ASSERT_LT(stored, 13);
  EXPECT_NE(r.output.find("iterations 0.." + std::to_string(stored - 1) + " are stored"), std::string::npos) << r.output;
  EXPECT_EQ(Kgd("designs " + file).exit_code, 0);
  EXPECT_EQ(Kgd("check " + file).exit_code, 0);
  ASSERT_EQ(Shell("mount -o remount,size=64m " + disk).exit_code, 0);
  const CommandRun resumed = Kgd("design --resume " + file + " --iterations 12");
  ASSERT_EQ(resumed.exit_code, 0) << resumed.output;
  ExpectSameDesigns(Path("whole.h5"), file);
}

// libfiu's POSIX preload makes every pwrite fail with ENOSPC: the file cannot even be started, and the
// message names the system's error.
TEST_F(StorageFaults, NoSpaceIsNamedAsTheSystemSaysIt) {
  if (Shell("command -v fiu-run").exit_code != 0) GTEST_SKIP() << "fiu-run (Debian's fiu-utils) is not installed";
  const CommandRun r = Shell("fiu-run -x -c 'enable name=posix/io/rw/pwrite,failinfo=28' " + std::string(KGD_BINARY) + " " + kJob +
                             " --iterations 3 --out " + Path("nospace.h5"));
  EXPECT_EQ(r.exit_code, 4) << r.output;
  EXPECT_NE(r.output.find("No space left on device (ENOSPC)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find(Path("nospace.h5")), std::string::npos) << r.output;
}

// The offset and size of the chunk of `dataset` that holds row `row` (one row per chunk).
std::pair<haddr_t, hsize_t> ChunkOf(const std::string& path, const char* dataset, hsize_t row) {
  const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  const hid_t set = H5Dopen2(file, dataset, H5P_DEFAULT);
  std::array<hsize_t, 3> offset{row, 0, 0};
  unsigned mask = 0;
  haddr_t addr = HADDR_UNDEF;
  hsize_t size = 0;
  H5Dget_chunk_info_by_coord(set, offset.data(), &mask, &addr, &size);
  H5Dclose(set);
  H5Fclose(file);
  return {addr, size};
}

// 64 bytes inverted in the middle of iteration 7's positions: every reader names the damaged iteration
// instead of serving it, `kgd check` says what can be kept, and a resume rebuilds from it.
TEST_F(StorageFaults, AFlippedBitIsNamedByEveryReader) {
  ASSERT_EQ(Kgd(kJob + " --iterations 12 --out " + Path("d.h5")).exit_code, 0);
  const auto [addr, size] = ChunkOf(Path("d.h5"), "/iterations/positions", 7);
  ASSERT_NE(addr, HADDR_UNDEF);
  ASSERT_GT(size, 128u);
  {
    std::fstream f(Path("d.h5"), std::ios::in | std::ios::out | std::ios::binary);
    std::vector<char> bytes(64);
    f.seekg(addr + size / 2);
    f.read(bytes.data(), 64);
    for (char& c : bytes) c = static_cast<char>(~c);
    f.seekp(addr + size / 2);
    f.write(bytes.data(), 64);
  }
  CommandRun r = Kgd("designs " + Path("d.h5"));
  EXPECT_EQ(r.exit_code, 5) << r.output;
  EXPECT_NE(r.output.find("iteration 7 is damaged: /iterations/positions"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("iterations 0..6 are intact"), std::string::npos) << r.output;
  r = Kgd("check " + Path("d.h5"));
  EXPECT_EQ(r.exit_code, 5) << r.output;
  EXPECT_NE(r.output.find("1 of 13 iterations damaged"), std::string::npos) << r.output;
  r = Kgd("check --json " + Path("d.h5"));
  EXPECT_NE(r.output.find("\"intact\":7"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("\"damaged\":[7]"), std::string::npos) << r.output;
  r = Kgd("evaluate " + Path("d.h5") + " --iteration 7");
  EXPECT_NE(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("iteration 7 is damaged"), std::string::npos) << r.output;
  // The other iterations are served as before.
  EXPECT_EQ(Kgd("evaluate " + Path("d.h5") + " --iteration 6").exit_code, 0);
  r = Kgd("design --resume " + Path("d.h5") + " --iterations 12");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("kept 7 of 13"), std::string::npos) << r.output;
  EXPECT_TRUE(fs::exists(Path("d.h5.damaged")));
  EXPECT_EQ(Kgd("check " + Path("d.h5")).exit_code, 0);
}

// A second run onto a design file that a first run is writing is refused, naming the holder; the first
// finishes with a file that reads back. An existing file is replaced only with --overwrite.
TEST_F(StorageFaults, OneWriterPerFile) {
  using test_support::Process;
  Process first = Process::Spawn({KGD_BINARY, "design", "pull_test_all_cloth", "--budget", "0.1", "--er", "0.02", "--ar-max", "0.02", "--json",
                                  "--out", Path("same.h5")},
                                 Path("first.log"));
  // Wait until the first run has stored an iteration.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  while (StoredIterations(Path("same.h5")) < 1 && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  ASSERT_GE(StoredIterations(Path("same.h5")), 1);
  CommandRun r = Kgd(kJob + " --iterations 3 --overwrite --out " + Path("same.h5"));
  EXPECT_EQ(r.exit_code, 4) << r.output;
  EXPECT_NE(r.output.find("another writer has it open"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("process " + std::to_string(first.pid)), std::string::npos) << r.output;
  r = Kgd("design --resume " + Path("same.h5"));
  EXPECT_EQ(r.exit_code, 4) << r.output;
  EXPECT_NE(r.output.find("another writer has it open"), std::string::npos) << r.output;
  const int status = first.Wait();
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << status;
  EXPECT_EQ(Kgd("check " + Path("same.h5")).exit_code, 0);
  // Without --overwrite an existing file stays as it is.
  const int before = StoredIterations(Path("same.h5"));
  r = Kgd(kJob + " --iterations 2 --out " + Path("same.h5"));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--overwrite replaces it"), std::string::npos) << r.output;
  EXPECT_EQ(StoredIterations(Path("same.h5")), before);
  ASSERT_EQ(Kgd(kJob + " --iterations 2 --overwrite --out " + Path("same.h5")).exit_code, 0);
  EXPECT_EQ(StoredIterations(Path("same.h5")), 3);
}

}  // namespace
}  // namespace kgd
