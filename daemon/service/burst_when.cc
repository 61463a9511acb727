#include "daemon/service/burst_when.h"

#include <stdexcept>

namespace dfsm::service {

const char* BurstWhenName(BurstWhen when) { return when == BurstWhen::kNext ? "next" : "last"; }

BurstWhen ParseBurstWhen(const std::string& name) {
  if (name == "last") return BurstWhen::kLast;
  if (name == "next") return BurstWhen::kNext;
  throw std::invalid_argument("when must be \"last\" or \"next\", not \"" + name + "\"");
}

}  // namespace dfsm::service
