// estimator: the floating-base state estimator process (its binding: hpr/graph/bindings.hpp,
// EstimatorBinding).
#include "hpr/graph/bindings.hpp"

int main(int argc, char** argv) { return hpr::graph::run_node<hpr::graph::EstimatorBinding>(argc, argv); }
