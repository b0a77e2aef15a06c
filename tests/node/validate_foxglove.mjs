// Validates messages against Foxglove's own JSON schemas. FILE holds a JSON array of
// {"schemaName": "foxglove.X", "message": {...}}. Prints {"validated": {name: count}, "invalid": [...]}.
//   node validate_foxglove.mjs FILE
import fs from "node:fs";
import { foxgloveErrors } from "./foxglove_schemas.mjs";

const result = { validated: {}, invalid: [] };
for (const { schemaName, message } of JSON.parse(fs.readFileSync(process.argv[2], "utf8"))) {
  const errors = foxgloveErrors(schemaName, message);
  if (errors) result.invalid.push({ schemaName, errors: errors.slice(0, 5) });
  else result.validated[schemaName] = (result.validated[schemaName] ?? 0) + 1;
}
console.log(JSON.stringify(result));
