// Runs the Khronos glTF validator on one or more .glb/.gltf files and prints, per file, the
// report's counts and its first messages. Exits 0 only when every file has zero errors, so
// tests and scripts can use the exit status alone:
//
//   node tools/gltf-validator/validate.mjs out.glb [more.glb ...] [--all]
//
// --all prints every message instead of the first few. External resources of a .gltf (buffers,
// images) are read relative to the file, so inputs can be checked as well as the GLBs we write.
// Exit status: 0 clean, 1 a file has errors, 2 a file could not be read or validated.
import { readFile } from 'node:fs/promises';
import path from 'node:path';
import validator from 'gltf-validator';

const FIRST_MESSAGES = 8;
const SEVERITY = ['error', 'warning', 'info', 'hint'];

async function validate(file) {
  const bytes = new Uint8Array(await readFile(file));
  return validator.validateBytes(bytes, {
    uri: path.basename(file),
    maxIssues: 0,  // unlimited, so numErrors counts every error and the report is never truncated
    writeTimestamp: false,
    externalResourceFunction: async (uri) =>
      new Uint8Array(await readFile(path.resolve(path.dirname(file), decodeURIComponent(uri)))),
  });
}

function summarise(file, report, all) {
  const issues = report.issues;
  console.log(`${file}: ${issues.numErrors} errors, ${issues.numWarnings} warnings, ` +
              `${issues.numInfos} infos, ${issues.numHints} hints (glTF validator ${report.validatorVersion})`);
  // Errors first, then warnings, infos and hints, each in report order.
  const messages = [...issues.messages].sort((a, b) => a.severity - b.severity);
  const shown = all ? messages : messages.slice(0, FIRST_MESSAGES);
  for (const m of shown) {
    console.log(`  ${SEVERITY[m.severity] ?? m.severity} ${m.code} ${m.pointer ?? ''}: ${m.message}`);
  }
  if (shown.length < messages.length) console.log(`  ... ${messages.length - shown.length} more (--all lists them)`);
  return issues.numErrors === 0;
}

const args = process.argv.slice(2);
const all = args.includes('--all');
const files = args.filter((a) => a !== '--all');
if (files.length === 0) {
  console.error('usage: node validate.mjs FILE.glb [FILE ...] [--all]');
  process.exit(2);
}
let status = 0;
for (const file of files) {
  try {
    if (!summarise(file, await validate(file), all)) status = Math.max(status, 1);
  } catch (error) {
    console.error(`${file}: not validated: ${error}`);
    status = 2;
  }
}
process.exit(status);
