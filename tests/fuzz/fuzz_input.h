// Shared by the fuzz targets: the readers take a path, so each input is written to a per-process
// file in memory (/dev/shm) with the extension that picks the reader. Only the project's
// documented error (InputError) is expected; anything else escapes and is a finding.
#pragma once

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <string>

#include "base/errors.h"

namespace cvt::fuzz {

// The file every input of this process goes to, e.g. /dev/shm/cvtmesh-fuzz-123/input.nii.
// Its own folder, so that a detached data file named by a header stays inside it.
inline std::string input_path(const std::string& extension) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path base =
      fs::is_directory("/dev/shm", ec) ? fs::path("/dev/shm") : fs::temp_directory_path();
  const fs::path dir = base / ("cvtmesh-fuzz-" + std::to_string(::getpid()));
  fs::create_directories(dir, ec);
  return (dir / ("input" + extension)).string();
}

// Writes `data` to the input file and runs `read` on its path; InputError is the expected
// answer to a bad file, every other exception propagates (libFuzzer reports it).
template <class Read>
int run_on_file(const std::uint8_t* data, std::size_t size, const std::string& extension,
                Read read) {
  const std::string path = input_path(extension);
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) return 0;  // not the code under test
  const bool written = std::fwrite(data, 1, size, f) == size;
  std::fclose(f);
  if (!written) return 0;
  try {
    read(path);
  } catch (const InputError&) {
  }
  std::remove(path.c_str());
  return 0;
}

// True when the input starts with the gzip magic (so it goes to a .gz name).
inline bool is_gzip(const std::uint8_t* data, std::size_t size) {
  return size >= 2 && data[0] == 0x1f && data[1] == 0x8b;
}

}  // namespace cvt::fuzz
