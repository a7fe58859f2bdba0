"""Write the plant FMU's modelDescription.xml from the variable table in navkit_plant.h.

Usage: gen_model_description.py {3|2} HEADER OUT [MODEL_IDENTIFIER]

The header is the single source: PLANT_VARIABLES lines (one F64/I32/STR/BIN entry per line),
PLANT_MODEL_NAME, PLANT_MODEL_DESCRIPTION and PLANT_INSTANTIATION_TOKEN. Value reference = the
entry's position in the table. FMI 2.0 has no Binary type: its description leaves the BIN
entries out (their value references stay unused). Standard library only.
"""

import re
import sys
from pathlib import Path
from xml.sax.saxutils import quoteattr

ENTRY = re.compile(
    r'^\s*(F64|I32|STR|BIN)\((\w+),\s*(INDEPENDENT|PARAMETER|INPUT|OUTPUT),\s*'
    r'("(?:[^"\\]|\\.)*"|[-+0-9.eE]+),\s*"([^"]*)",\s*"([^"]*)"\)\s*\\?\s*$')
DEFINE = re.compile(r'^#define\s+(PLANT_MODEL_NAME|PLANT_MODEL_DESCRIPTION|PLANT_INSTANTIATION_TOKEN)\s+"([^"]*)"\s*$')


def parse(header: Path):
    """(defines, variables) from the header; variables are dicts in table order."""
    defines, variables, in_table = {}, [], False
    for lineno, line in enumerate(header.read_text().splitlines(), 1):
        m = DEFINE.match(line)
        if m:
            defines[m.group(1)] = m.group(2)
        if line.startswith('#define PLANT_VARIABLES('):
            in_table = True
            continue
        if not in_table:
            continue
        m = ENTRY.match(line)
        if not m:
            raise SystemExit(f'{header}:{lineno}: not a table entry: {line.strip()}')
        kind, name, caus, start, unit, desc = m.groups()
        if kind in ('STR', 'BIN'):
            if not start.startswith('"'):
                raise SystemExit(f'{header}:{lineno}: {name}: string start expected')
            if kind == 'BIN' and caus != 'OUTPUT':
                raise SystemExit(f'{header}:{lineno}: {name}: a Binary must be an OUTPUT '
                                 f'(this generator writes no Binary start values)')
            start = start[1:-1]
        elif start.startswith('"'):
            raise SystemExit(f'{header}:{lineno}: {name}: numeric start expected')
        variables.append(dict(kind=kind, name=name, causality=caus.lower(), start=start,
                              unit=unit, description=desc, vr=len(variables)))
        if not line.rstrip().endswith('\\'):
            break
    names = [v['name'] for v in variables]
    dup = {n for n in names if names.count(n) > 1}
    if dup:
        raise SystemExit(f'{header}: duplicate variable names {sorted(dup)}')
    for key in ('PLANT_MODEL_NAME', 'PLANT_MODEL_DESCRIPTION', 'PLANT_INSTANTIATION_TOKEN'):
        if key not in defines:
            raise SystemExit(f'{header}: #define {key} "..." not found')
    return defines, variables


def fmt_start(v):
    """The start value as the XML wants it."""
    if v['kind'] == 'F64':
        return repr(float(v['start']))
    if v['kind'] == 'I32':
        return str(int(v['start']))
    return v['start']


def variability(v):
    """fixed for parameters, continuous for Float64, discrete otherwise."""
    if v['causality'] == 'parameter':
        return 'fixed'
    if v['kind'] == 'F64':
        return 'continuous'
    return 'discrete'


def units(variables):
    return sorted({v['unit'] for v in variables if v['kind'] == 'F64' and v['unit']})


def fmi3(defines, variables, model_id):
    out = ['<?xml version="1.0" encoding="UTF-8"?>',
           '<fmiModelDescription fmiVersion="3.0"'
           f' modelName={quoteattr(defines["PLANT_MODEL_NAME"])}'
           f' description={quoteattr(defines["PLANT_MODEL_DESCRIPTION"])}'
           f' instantiationToken={quoteattr(defines["PLANT_INSTANTIATION_TOKEN"])}'
           ' generationTool="navkit fmu/plant/gen_model_description.py" variableNamingConvention="flat">',
           f'  <CoSimulation modelIdentifier="{model_id}" canHandleVariableCommunicationStepSize="true"'
           ' canGetAndSetFMUState="false" canSerializeFMUState="false" hasEventMode="false"'
           ' providesIntermediateUpdate="false" canReturnEarlyAfterIntermediateUpdate="false"/>',
           '  <UnitDefinitions>']
    out += [f'    <Unit name={quoteattr(u)}/>' for u in units(variables)]
    out += ['  </UnitDefinitions>',
            '  <LogCategories>',
            '    <Category name="logEvents" description="Informational messages"/>',
            '    <Category name="logStatusError" description="Errors (always logged)"/>',
            '  </LogCategories>',
            '  <DefaultExperiment startTime="0" stopTime="10" stepSize="0.001"/>',
            '  <ModelVariables>']
    tag = {'F64': 'Float64', 'I32': 'Int32', 'STR': 'String', 'BIN': 'Binary'}
    for v in variables:
        attrs = (f'name="{v["name"]}" valueReference="{v["vr"]}" description={quoteattr(v["description"])}'
                 f' causality="{v["causality"]}" variability="{variability(v)}"')
        if v['kind'] == 'F64' and v['unit']:
            attrs += f' unit={quoteattr(v["unit"])}'
        if v['causality'] in ('parameter', 'input'):
            if v['kind'] == 'STR':
                out.append(f'    <String {attrs}>')
                out.append(f'      <Start value={quoteattr(fmt_start(v))}/>')
                out.append('    </String>')
                continue
            attrs += f' start="{fmt_start(v)}"'
        out.append(f'    <{tag[v["kind"]]} {attrs}/>')
    out.append('  </ModelVariables>')
    out.append('  <ModelStructure>')
    outputs = [v for v in variables if v['causality'] == 'output']
    out += [f'    <Output valueReference="{v["vr"]}"/>' for v in outputs]
    out += [f'    <InitialUnknown valueReference="{v["vr"]}"/>' for v in outputs]
    out.append('  </ModelStructure>')
    out.append('</fmiModelDescription>')
    return '\n'.join(out) + '\n'


def fmi2(defines, variables, model_id):
    out = ['<?xml version="1.0" encoding="UTF-8"?>',
           '<fmiModelDescription fmiVersion="2.0"'
           f' modelName={quoteattr(defines["PLANT_MODEL_NAME"])}'
           f' description={quoteattr(defines["PLANT_MODEL_DESCRIPTION"])}'
           f' guid={quoteattr(defines["PLANT_INSTANTIATION_TOKEN"])}'
           ' generationTool="navkit fmu/plant/gen_model_description.py" variableNamingConvention="flat"'
           f' numberOfEventIndicators="0">',
           f'  <CoSimulation modelIdentifier="{model_id}" canHandleVariableCommunicationStepSize="true"'
           ' canGetAndSetFMUstate="false" canSerializeFMUstate="false"/>',
           '  <UnitDefinitions>']
    out += [f'    <Unit name={quoteattr(u)}/>' for u in units(variables)]
    out += ['  </UnitDefinitions>',
            '  <LogCategories>',
            '    <Category name="logEvents" description="Informational messages"/>',
            '    <Category name="logStatusError" description="Errors (always logged)"/>',
            '  </LogCategories>',
            '  <DefaultExperiment startTime="0" stopTime="10" stepSize="0.001"/>',
            '  <ModelVariables>']
    tag = {'F64': 'Real', 'I32': 'Integer', 'STR': 'String'}
    variables = [v for v in variables if v['kind'] != 'BIN']    # no Binary in FMI 2.0
    index = {}
    for v in variables:
        index[v['vr']] = len(index) + 1
        attrs = (f'name="{v["name"]}" valueReference="{v["vr"]}" description={quoteattr(v["description"])}'
                 f' causality="{v["causality"]}" variability="{variability(v)}"')
        inner = ''
        if v['kind'] == 'F64' and v['unit']:
            inner += f' unit={quoteattr(v["unit"])}'
        if v['causality'] in ('parameter', 'input'):
            inner += f' start={quoteattr(fmt_start(v))}'
        out.append(f'    <ScalarVariable {attrs}>')
        out.append(f'      <{tag[v["kind"]]}{inner}/>')
        out.append('    </ScalarVariable>')
    out.append('  </ModelVariables>')
    out.append('  <ModelStructure>')
    outputs = [v for v in variables if v['causality'] == 'output']
    out.append('    <Outputs>')
    out += [f'      <Unknown index="{index[v["vr"]]}"/>' for v in outputs]
    out.append('    </Outputs>')
    out.append('    <InitialUnknowns>')
    out += [f'      <Unknown index="{index[v["vr"]]}"/>' for v in outputs]
    out.append('    </InitialUnknowns>')
    out.append('  </ModelStructure>')
    out.append('</fmiModelDescription>')
    return '\n'.join(out) + '\n'


def main(argv):
    if len(argv) not in (4, 5) or argv[1] not in ('2', '3'):
        raise SystemExit(__doc__)
    defines, variables = parse(Path(argv[2]))
    model_id = argv[4] if len(argv) == 5 else defines['PLANT_MODEL_NAME']
    text = (fmi3 if argv[1] == '3' else fmi2)(defines, variables, model_id)
    out = Path(argv[3])
    out.parent.mkdir(parents=True, exist_ok=True)
    if not out.exists() or out.read_text() != text:
        out.write_text(text)


if __name__ == '__main__':
    main(sys.argv)
