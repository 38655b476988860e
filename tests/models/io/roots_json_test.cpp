// Poles and zeros as JSON: [re, im] pairs in their order, checked against values written by hand.

#include "models/io/roots_json.h"

#include <gtest/gtest.h>

namespace panelbass::models {
namespace {

TEST(RootsJson, EachRootIsARealImaginaryPairInOrder) {
  Eigen::VectorXcd roots(3);
  roots << std::complex<double>(0.5, 0.25), std::complex<double>(0.5, -0.25), std::complex<double>(-0.9, 0.0);
  EXPECT_EQ(roots_json(roots), nlohmann::json::parse("[[0.5, 0.25], [0.5, -0.25], [-0.9, 0.0]]"));
}

TEST(RootsJson, NoRootsIsAnEmptyArray) {
  const nlohmann::json none = roots_json(Eigen::VectorXcd());
  EXPECT_TRUE(none.is_array());
  EXPECT_TRUE(none.empty());
}

}  // namespace
}  // namespace panelbass::models
