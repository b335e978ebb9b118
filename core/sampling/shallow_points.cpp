#include "sampling/shallow_points.h"

#include <string>

#include "sampling/cvt_sampling.h"
#include "base/errors.h"

namespace cvt {

ShallowResult remove_shallow_points(const std::vector<Vec3>& sites_world,
                                    const std::vector<std::int32_t>& boundary_owners) {
  std::vector<char> shallow(sites_world.size(), 0);
  for (std::int32_t owner : boundary_owners) {
    if (owner < 0) continue;
    if (std::size_t(owner) >= sites_world.size())
      throw InputError("shallow points: boundary owner " + std::to_string(owner) +
                       " is not one of the " + std::to_string(sites_world.size()) + " sites");
    shallow[owner] = 1;
  }
  ShallowResult r;
  for (std::size_t s = 0; s < sites_world.size(); ++s) {
    (shallow[s] ? r.removed_world : r.kept_world).push_back(sites_world[s]);
    (shallow[s] ? r.removed_index : r.kept_index).push_back(std::int32_t(s));
  }
  return r;
}

ShallowResult remove_shallow_points(const Grid& grid, const std::vector<Vec3>& sites_world,
                                    const std::vector<std::int32_t>& boundary) {
  // The nearest-site search works in the grid's local frame (spacing ⊙ index).
  std::vector<Vec3> local(sites_world.size());
  for (std::size_t s = 0; s < sites_world.size(); ++s)
    local[s] = grid.index_to_local(grid.world_to_index(sites_world[s]));
  return remove_shallow_points(sites_world, nearest_site_owners(grid, local, boundary));
}

}  // namespace cvt
