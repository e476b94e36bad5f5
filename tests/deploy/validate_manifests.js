#!/usr/bin/env node
// Validates Kubernetes objects against the API's schemas: kubernetes-models (the core and apps APIs) and
// @kubernetes-models/keda (ScaledObject), both locked in this folder's package-lock.json.
//
// Usage: node validate_manifests.js OBJECTS.json   (a JSON array of objects, as a renderer gives them)
// Prints one line per problem, "KIND NAMESPACE/NAME: FIELD: MESSAGE", then "N objects, M problems".
// Exit 0: every object fits its schema; 1: some object does not; 2: the input could not be read.
//
// Besides the schema's types, enums and required fields, a field that the schema does not describe is a
// problem (as the API server's strict field validation rejects it). The schemas come as compiled
// validators, so the fields they describe are found by watching which ones the validator reads: a
// validator reads every property its schema names (to test whether it is present), and every key of a
// map (labels, resources, a KEDA trigger's metadata). A key of a validated object that was never read is
// not in the schema. An object whose validator read none of its keys is free-form and is not judged.
"use strict";
const fs = require("fs");

function modelClass(apiVersion, kind) {
  if (typeof apiVersion !== "string" || typeof kind !== "string" || !/^[\w.\/-]+$/.test(apiVersion)) return null;
  for (const pkg of ["kubernetes-models", "@kubernetes-models/keda"]) {
    let mod;
    try {
      mod = require(`${pkg}/${apiVersion}`);
    } catch (e) {
      continue;
    }
    if (mod[kind] && mod[kind].kind === kind) return mod[kind];
  }
  return null;
}

// "/spec/template/spec/containers/0/ports/0" -> "spec.template.spec.containers[0].ports[0]"
function fieldName(pointer) {
  let out = "";
  for (const part of pointer.split("/").slice(1)) {
    const key = part.replace(/~1/g, "/").replace(/~0/g, "~");
    if (/^\d+$/.test(key)) out += `[${key}]`;
    else if (/^[A-Za-z_$][\w$]*$/.test(key)) out += (out ? "." : "") + key;
    else out += `[${JSON.stringify(key)}]`;
  }
  return out || "(the object)";
}

// Wraps data so that every key read through it is recorded in reads (pointer -> Set of keys).
function watched(data, pointer, reads) {
  if (data === null || typeof data !== "object") return data;
  if (!reads.has(pointer)) reads.set(pointer, new Set());
  return new Proxy(data, {
    get(target, key) {
      const value = target[key];
      if (typeof key !== "string" || !Object.prototype.hasOwnProperty.call(target, key)) return value;
      reads.get(pointer).add(key);
      return watched(value, `${pointer}/${key.replace(/~/g, "~0").replace(/\//g, "~1")}`, reads);
    },
    has(target, key) {
      if (typeof key === "string") reads.get(pointer).add(key);
      return key in target;
    },
  });
}

function unknownFields(data, pointer, reads, out) {
  if (data === null || typeof data !== "object") return;
  const read = reads.get(pointer);
  if (!read) return; // the validator did not descend here (its parent already failed)
  if (!Array.isArray(data) && read.size > 0) {
    for (const key of Object.keys(data)) {
      if (!read.has(key)) out.push({ field: fieldName(`${pointer}/${key}`), message: "is not a field of the schema" });
    }
  }
  for (const key of Object.keys(data)) {
    unknownFields(data[key], `${pointer}/${key.replace(/~/g, "~0").replace(/\//g, "~1")}`, reads, out);
  }
}

function validate(obj) {
  const problems = [];
  const cls = modelClass(obj && obj.apiVersion, obj && obj.kind);
  if (!cls) return [{ field: "apiVersion/kind", message: `no schema for ${obj && obj.apiVersion} ${obj && obj.kind}` }];
  const reads = new Map();
  try {
    cls.prototype.validate.call(watched(obj, "", reads));
  } catch (e) {
    if (!Array.isArray(e.errors)) throw e;
    for (const err of e.errors) {
      const missing = err.keyword === "required" ? `/${err.params.missingProperty}` : "";
      const allowed = err.keyword === "enum" ? ` (${err.params.allowedValues.join(", ")})` : "";
      problems.push({ field: fieldName(err.instancePath + missing), message: (missing ? "is required" : err.message) + allowed });
    }
  }
  unknownFields(obj, "", reads, problems);
  return problems;
}

function main() {
  let objects;
  try {
    objects = JSON.parse(fs.readFileSync(process.argv[2], "utf8"));
    if (!Array.isArray(objects)) throw new Error("not a JSON array");
  } catch (e) {
    console.error(`validate_manifests: ${process.argv[2]}: ${e.message}`);
    return 2;
  }
  let count = 0;
  for (const obj of objects) {
    const meta = (obj && obj.metadata) || {};
    const who = `${obj && obj.kind} ${meta.namespace ? meta.namespace + "/" : ""}${meta.name}`;
    const seen = new Set();
    for (const p of validate(obj)) {
      const line = `${who}: ${p.field}: ${p.message}`;
      if (seen.has(line)) continue; // an anyOf reports the same field once per branch
      seen.add(line);
      console.log(line);
      count++;
    }
  }
  console.log(`${objects.length} objects, ${count} problems`);
  return count ? 1 : 0;
}

process.exitCode = main();
