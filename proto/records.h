// BESO iterations and garments between the core/store types and their kgd.v1 messages. Arrays travel
// as flat repeated fields (positions x0 y0 z0 x1 ...); doubles are copied bit for bit.
#pragma once

#include "core/beso/design_loop.h"
#include "kgd/v1/kgd.pb.h"
#include "store/design_evaluation.h"
#include "store/design_file.h"

namespace kgd {

// Every KGD_BESO_METRICS entry (core/beso/design_loop.h) has its kgd.v1.IterationMetrics field of the
// same name and type; the conversions below carry the metrics by that list.
Status CheckMetricFields();

v1::IterationMetrics MetricsToProto(const BesoIteration& it);
// Metrics only (arrays empty).
BesoIteration MetricsFromProto(const v1::IterationMetrics& m);

struct RecordArrays {
  bool design = true, positions = true, energy_density = true, sensitivity = true;
};
v1::IterationRecord RecordToProto(const BesoIteration& it, const RecordArrays& arrays = {});
// Errors: arrays that do not fit `faces` / `vertices` (0: not checked), a status name that is unknown.
Result<BesoIteration> RecordFromProto(const v1::IterationRecord& record, int faces = 0, int vertices = 0);

v1::Garment GarmentToProto(const DesignFileHeader& header);
// Fills the garment part of `header` (rest mesh, initial positions, areas, attachments).
Status GarmentFromProto(const v1::Garment& garment, DesignFileHeader* header);

v1::DesignEvaluation EvaluationToProto(const DesignEvaluation& evaluation);
// Errors: arrays that do not fit `faces` / `vertices` / `body_vertices` (0: not checked).
Result<DesignEvaluation> EvaluationFromProto(const v1::DesignEvaluation& evaluation, int faces = 0, int vertices = 0, int body_vertices = 0);

}  // namespace kgd
