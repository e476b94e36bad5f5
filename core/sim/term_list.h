// The energy terms of the garment system, listed once. A new term is its own files (energy_term.h
// says what they hold) plus one line here and, for its effect switch and time metric, its fields in
// the proto (kgd.v1.SceneEffects.<effect>, kgd.v1.IterationMetrics.<key>_s).
//
// Each line: X(Y, Class, key, EffectType, effect, default, effect_what, time_what), where Y is passed
// through (the list's users expand it inside their own X lists):
//  - Class: the factory Make<Class>Term (beside the term, in its own .cpp) makes the term from a
//    TermContext, or returns nullptr when the model's effects leave it off;
//  - key: the term's name in the energy breakdown, in messages (with spaces) and in the time table;
//    its evaluation time is the BESO profile metric <key>_s (core/beso/design_loop.h), whose meaning
//    is time_what;
//  - effect: the member of Effects (garment_model.h) that switches the term, of EffectType with its
//    default; the scene file's key effects.<effect> (core/scene/scene_keys.h), meaning effect_what.
//    EffectType is bool, double (0: off) or ContactModel; the scene loader reads each by its type.
// The order is the order an element sums the terms of its stencil, and the order the energy breakdown
// lists and totals them in.
#pragma once

#define KGD_ENERGY_TERMS(X, Y)                                                                                              \
  X(Y, Membrane, membrane, bool, membrane, true, "the StVK membrane (default true)", "membrane term evaluations")          \
  X(Y, Contact, contact, ContactModel, contact, ContactModel::kNone, "\"none\" (default), \"unilateral\" or \"bilateral\"",  \
    "contact term evaluations with their body-field queries (0: not built)")                                               \
  X(Y, Attachment, attachment, bool, attachments, false, "the attachment springs (default false)",                         \
    "attachment term evaluations (0: not built)")                                                                          \
  X(Y, FoldBarrier, fold_barrier, bool, fold_barrier, true, "the barrier against folded triangles (default true)",         \
    "fold barrier term evaluations (0: not built)")                                                                        \
  X(Y, Friction, friction, double, friction, 0.0, "Coulomb coefficient mu (default 0; needs contact)",                     \
    "friction term evaluations (0: not built)")                                                                            \
  X(Y, Bending, bending, bool, bending, false, "discrete-shell bending of the cloth (default false)",                      \
    "bending term evaluations (0: not built)")                                                                             \
  X(Y, UniformPressure, uniform_pressure, double, uniform_pressure_Pa, 0.0, "pressure along the rest normals, Pa (default 0)", "uniform pressure term evaluations (0: not built)") \
  /* a new term: one line above this one */
