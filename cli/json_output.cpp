#include "cli/json_output.h"

#include <iostream>

namespace panelbass::cli {

void print_result(const nlohmann::json& result) { std::cout << result.dump(2) << std::endl; }

}  // namespace panelbass::cli
