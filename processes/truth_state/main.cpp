// truth_state: the simulator's true state on ROBOT_STATE, in the estimator's place (its binding:
// hpr/graph/bindings.hpp, TruthStateBinding; the component: hpr/estimator/truth_state.hpp).
#include "hpr/graph/bindings.hpp"

int main(int argc, char** argv) { return hpr::graph::run_node<hpr::graph::TruthStateBinding>(argc, argv); }
