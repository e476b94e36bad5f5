// The energy terms of the garment system, listed once. A new term is its own files (energy_term.h
// says what they hold) plus one line here and, for its effect switch and time metric, its fields in
// the proto (kgd.v1.SceneEffects.<effect>, kgd.v1.IterationMetrics.<key>_s).
//
// Each line: X(Y, Class, key, sum_place, EffectType, effect, default, effect_what, time_what), where Y is
// passed through (the list's users expand it inside their own X lists):
//  - Class: the factory Make<Class>Term (beside the term, in its own .cpp) makes the term from a
//    TermContext, or returns nullptr when the model's effects leave it off;
//  - key: the term's name in the energy breakdown, in messages (with spaces) and in the time table;
//    its evaluation time is the BESO profile metric <key>_s (core/beso/design_loop.h), whose meaning
//    is time_what;
//  - sum_place: the term's place in the order an element sums the terms of its stencil (0 first; each
//    place once). The faces sum membrane, fold barrier, attachment, uniform pressure; the vertices
//    contact, friction: results depend on that order in the last bit;
//  - effect: the member of Effects (garment_model.h) that switches the term, of EffectType with its
//    default; the scene file's key effects.<effect> (core/scene/scene_keys.h), meaning effect_what.
//    EffectType is bool, double (0: off) or ContactModel; the scene loader reads each by its type.
// The list's order is the order the energy breakdown lists and totals the terms in.
#pragma once

#define KGD_ENERGY_TERMS(X, Y)                                                                                              \
  X(Y, Membrane, membrane, 0, bool, membrane, true, "the StVK membrane (default true)", "membrane term evaluations")          \
  X(Y, Contact, contact, 3, ContactModel, contact, ContactModel::kNone, "\"none\" (default), \"unilateral\" or \"bilateral\"",  \
    "contact term evaluations with their body-field queries (0: not built)")                                               \
  X(Y, Attachment, attachment, 2, bool, attachments, false, "the attachment springs (default false)",                         \
    "attachment term evaluations (0: not built)")                                                                          \
  X(Y, FoldBarrier, fold_barrier, 1, bool, fold_barrier, true, "the barrier against folded triangles (default true)",         \
    "fold barrier term evaluations (0: not built)")                                                                        \
  X(Y, Friction, friction, 4, double, friction, 0.0, "Coulomb coefficient mu (default 0; needs contact)",                     \
    "friction term evaluations (0: not built)")                                                                            \
  X(Y, Bending, bending, 5, bool, bending, false, "discrete-shell bending of the cloth (default false)",                      \
    "bending term evaluations (0: not built)")                                                                             \
  X(Y, UniformPressure, uniform_pressure, 6, double, uniform_pressure_Pa, 0.0, "pressure along the rest normals, Pa (default 0)", "uniform pressure term evaluations (0: not built)") \
  /* a new term: one line above this one */
