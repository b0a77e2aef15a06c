// Foxglove's own JSON schemas (@foxglove/schemas) compiled with a JSON-schema validator (ajv):
// checks that a message locview sends is what Foxglove expects under its schema name.
import schemas from "@foxglove/schemas/jsonschema.js";
import Ajv from "ajv";

const ajv = new Ajv({ strict: false });
const compiled = new Map();

// Returns null when `message` is a valid `schemaName` (e.g. "foxglove.Grid"), else the errors.
export function foxgloveErrors(schemaName, message) {
  const name = schemaName.replace(/^foxglove\./, "");
  if (!schemas[name]) return [`no Foxglove schema named ${schemaName}`];
  if (!compiled.has(name)) compiled.set(name, ajv.compile(schemas[name]));
  const validate = compiled.get(name);
  return validate(message) ? null : validate.errors.map((e) => `${e.instancePath} ${e.message}`);
}
