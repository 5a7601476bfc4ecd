#include "hpr/graph/bindings.hpp"

namespace hpr::graph {

// Every binding's channels are its component's declared ports, in order (the generic node checks
// it too, where it is instantiated: here it is checked once whatever is built).
static_assert(detail::channels_match_ports<EstimatorBinding>());
static_assert(detail::channels_match_ports<TruthStateBinding>());
static_assert(detail::channels_match_ports<PlannerBinding>());
static_assert(detail::channels_match_ports<ReferenceGenBinding>());
static_assert(detail::channels_match_ports<MotionOptBinding>());
static_assert(detail::channels_match_ports<WbcBinding>());

}  // namespace hpr::graph
