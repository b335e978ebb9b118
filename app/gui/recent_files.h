// The list of recently opened images, most recent first, kept in
// $XDG_CONFIG_HOME/cvtmesh/recent.txt (default ~/.config/cvtmesh/recent.txt), one path a line.
// GL-free.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace cvt::gui {

// The default file (empty when neither XDG_CONFIG_HOME nor HOME is set).
std::string default_recent_files_path();

class RecentFiles {
 public:
  explicit RecentFiles(std::string path, std::size_t capacity = 12);
  // Reads the file; a missing or unreadable file gives an empty list.
  void load();
  // Moves (or inserts) `file` to the front, trims to capacity and saves. Returns false when
  // the list could not be written (it is still updated in memory).
  bool add(const std::string& file);
  const std::vector<std::string>& files() const { return files_; }

 private:
  bool save() const;
  std::string path_;
  std::size_t capacity_;
  std::vector<std::string> files_;
};

}  // namespace cvt::gui
