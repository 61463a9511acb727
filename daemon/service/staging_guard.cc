#include "daemon/service/staging_guard.h"

#include <system_error>

namespace dfsm::service {

StagingGuard::~StagingGuard() {
  std::error_code ignored;
  if (!dir_.empty()) std::filesystem::remove_all(dir_, ignored);
}

}  // namespace dfsm::service
