// Per-stage budgets in ms, by the stage names of report.json (protocol's
// stage table) and "end_to_end", read from a JSON object {"hull": 40,
// "end_to_end": 300, ...}. A p95 over its budget is a violation; a
// budgeted stage with no sample in the run is reported as not measured,
// never as within. The live loop, the evaluation and the sweep all hold
// their runs against one.
#pragma once

#include <map>
#include <string>

#include "base/status.h"

namespace holofuse::protocol {

using Budget = std::map<std::string, double>;

// Unknown names and non-positive or non-numbers are refused, the valid
// names listed; the error names the file.
StatusOr<Budget> loadBudget(const std::string& path);
// A command line's --budget FILE: none when path is empty; an error says
// what is wrong with the file, under the flag's name.
StatusOr<Budget> loadBudgetFlag(const std::string& path);

}  // namespace holofuse::protocol
