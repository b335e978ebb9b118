#include "recent_files.h"

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "pipeline/preset.h"

namespace cvt::gui {

std::string default_recent_files_path() {
  namespace fs = std::filesystem;
  if (const char* xdg = std::getenv("XDG_CONFIG_HOME"); xdg && *xdg)
    return (fs::path(xdg) / "cvtmesh" / "recent.txt").string();
  if (const char* home = std::getenv("HOME"); home && *home)
    return (fs::path(home) / ".config" / "cvtmesh" / "recent.txt").string();
  return {};
}

RecentFiles::RecentFiles(std::string path, std::size_t capacity)
    : path_(std::move(path)), capacity_(capacity) {}

void RecentFiles::load() {
  files_.clear();
  if (path_.empty()) return;
  std::ifstream in(path_);
  std::string line;
  while (std::getline(in, line) && files_.size() < capacity_)
    if (!line.empty() && std::find(files_.begin(), files_.end(), line) == files_.end())
      files_.push_back(line);
}

bool RecentFiles::add(const std::string& file) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path absolute = fs::absolute(file, ec);
  const std::string entry = ec ? file : absolute.lexically_normal().string();
  files_.erase(std::remove(files_.begin(), files_.end(), entry), files_.end());
  files_.insert(files_.begin(), entry);
  if (files_.size() > capacity_) files_.resize(capacity_);
  return save();
}

bool RecentFiles::save() const {
  namespace fs = std::filesystem;
  if (path_.empty()) return false;
  std::error_code ec;
  fs::create_directories(fs::path(path_).parent_path(), ec);
  std::string text;
  for (const std::string& f : files_) text += f + "\n";
  try {
    write_file_atomically(path_, text);
  } catch (const std::exception&) {
    return false;
  }
  return true;
}

}  // namespace cvt::gui
