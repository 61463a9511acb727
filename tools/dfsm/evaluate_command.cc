#include "tools/dfsm/command.h"
