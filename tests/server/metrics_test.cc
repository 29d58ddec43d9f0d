#include "server/metrics.h"

#include <gtest/gtest.h>

#include <string>

#include "core/common/error.h"

namespace hgraph::server {
namespace {

TEST(Metrics, HandlesCountIntoTheirOwnFamilyAndSeries) {
  Metrics registry;
  const Counter calls = registry.DeclareCounter("calls_total", "Calls.");
  const Gauge depth = registry.DeclareGauge("depth", "Depth.");
  calls.Increment({{"method", "a"}});
  calls.Increment({{"method", "a"}}, 2);
  calls.Increment({{"method", "b"}});
  depth.Set({}, 7);
  EXPECT_EQ(calls.Value({{"method", "a"}}), 3);
  EXPECT_EQ(calls.Value({{"method", "b"}}), 1);
  EXPECT_EQ(calls.Value({{"method", "c"}}), 0);
  EXPECT_EQ(depth.Value(), 7);
  const std::string text = registry.Render();
  EXPECT_NE(text.find("# TYPE calls_total counter\n"), std::string::npos) << text;
  EXPECT_NE(text.find("calls_total{method=\"a\"} 3\n"), std::string::npos) << text;
  EXPECT_NE(text.find("depth 7\n"), std::string::npos) << text;
  // Declaration order is render order.
  EXPECT_LT(text.find("calls_total"), text.find("depth"));
}

TEST(Metrics, HistogramBucketsAreCumulative) {
  Metrics registry;
  const Histogram seconds = registry.DeclareHistogram("seconds", "Time.", {0.1, 1});
  seconds.Observe({}, 0.05);
  seconds.Observe({}, 0.5);
  seconds.Observe({}, 5);
  EXPECT_EQ(seconds.Count(), 3);
  const std::string text = registry.Render();
  EXPECT_NE(text.find("seconds_bucket{le=\"0.10000000000000001\"} 1\n"), std::string::npos) << text;
  EXPECT_NE(text.find("seconds_bucket{le=\"1\"} 2\n"), std::string::npos) << text;
  EXPECT_NE(text.find("seconds_bucket{le=\"+Inf\"} 3\n"), std::string::npos) << text;
  EXPECT_NE(text.find("seconds_sum 5.5499999999999998\n"), std::string::npos) << text;
}

TEST(Metrics, LabelValuesAreEscaped) {
  Metrics registry;
  const Counter c = registry.DeclareCounter("c_total", "C.");
  c.Increment({{"name", "a\"b\\c\nd"}});
  EXPECT_NE(registry.Render().find("c_total{name=\"a\\\"b\\\\c\\nd\"} 1\n"), std::string::npos)
      << registry.Render();
}

TEST(Metrics, DeclaringANameTwiceIsABug) {
  Metrics registry;
  registry.DeclareCounter("twice_total", "Once.");
  EXPECT_THROW(registry.DeclareGauge("twice_total", "Twice."), InternalError);
}

TEST(ServiceMetrics, DeclaresTheServiceFamiliesInOrder) {
  Metrics registry;
  ServiceMetrics families(registry);
  families.rpc_started.Increment({{"grpc_method", "GetSession"}});
  const std::string text = registry.Render();
  EXPECT_NE(text.find("grpc_server_started_total{grpc_method=\"GetSession\"} 1\n"),
            std::string::npos)
      << text;
  EXPECT_LT(text.find("grpc_server_started_total"), text.find("hgraph_admitted_calls"));
}

}  // namespace
}  // namespace hgraph::server
