"""IFC class → discipline: 'S' structural, 'A' architectural, 'M' mechanical, 'P' plumbing, 'E' electrical.

The rule, in order (first that applies wins):

1. **Parts** (``IfcBuildingElementPart``) take the discipline of the element they
   are a part of (``IfcRelAggregates``); an orphan part is 'A'. Any element that is a
   part of a window, door, curtain wall, stair, ramp or railing is 'A' whatever its own
   class (mullions are IfcMember, glazing IfcPlate, stringers IfcMember).
2. **Walls and slabs** (``IfcWall``, ``IfcSlab`` and subtypes, ``IfcWallStandardCase``,
   ``IfcSlabStandardCase``, ...) are 'S' when their common property set says
   ``LoadBearing = True`` (``Pset_WallCommon`` / ``Pset_SlabCommon``), else 'A'.
   A footing-like slab (``PredefinedType = BASESLAB``) is always 'S'.
3. **Generic MEP classes** — IFC2X3 has no ``IfcDuctSegment`` or ``IfcLightFixture``
   occurrence classes, only ``IfcFlowTerminal``, ``IfcFlowSegment``, ... — look at the
   element's type object: ``IfcLightFixtureType`` is read as ``IfcLightFixture`` and
   mapped by :data:`CLASS_DISCIPLINE`. Without a usable type, the element's
   distribution system (IFC4 ``IfcDistributionSystem.PredefinedType``) decides; failing
   that, :data:`GENERIC_DEFAULT` (mostly 'M').
4. **Every other class** is looked up in :data:`CLASS_DISCIPLINE`, walking up the IFC
   inheritance chain until a class is found (so ``IfcBeamStandardCase`` is 'S' via
   ``IfcBeam``). A class that no entry covers (``IfcBuildingElementProxy``, site,
   terrain) gets '' (unclassified).
"""

from __future__ import annotations

from functools import lru_cache

import ifcopenshell
import ifcopenshell.ifcopenshell_wrapper as _wrapper
import ifcopenshell.util.element as _uel

_S, _A, _M, _P, _E = "S", "A", "M", "P", "E"

#: Specific classes (and their subtypes) → discipline. Also used for type objects
#: with the ``Type``/``Style`` suffix removed.
CLASS_DISCIPLINE: dict[str, str] = {
    # structural
    **dict.fromkeys(
        [
            "IfcBeam",
            "IfcColumn",
            "IfcFooting",
            "IfcPile",
            "IfcMember",
            "IfcPlate",
            "IfcReinforcingElement",
            "IfcReinforcingBar",
            "IfcReinforcingMesh",
            "IfcTendon",
            "IfcTendonAnchor",
            "IfcTendonConduit",
            "IfcMechanicalFastener",
            "IfcFastener",
            "IfcDiscreteAccessory",
            "IfcElementAssembly",
            "IfcBearing",
            "IfcDeepFoundation",
            "IfcCaissonFoundation",
            "IfcBuildingElementComponent",
        ],
        _S,
    ),
    # architectural
    **dict.fromkeys(
        [
            "IfcWall",
            "IfcSlab",
            "IfcCurtainWall",
            "IfcDoor",
            "IfcWindow",
            "IfcCovering",
            "IfcRailing",
            "IfcStair",
            "IfcStairFlight",
            "IfcRamp",
            "IfcRampFlight",
            "IfcRoof",
            "IfcChimney",
            "IfcShadingDevice",
            "IfcFurnishingElement",
            "IfcFurniture",
            "IfcSystemFurnitureElement",
            "IfcBuildingElementPart",
        ],
        _A,
    ),
    # mechanical (HVAC, conveying)
    **dict.fromkeys(
        [
            "IfcDuctSegment",
            "IfcDuctFitting",
            "IfcDuctSilencer",
            "IfcAirTerminal",
            "IfcAirTerminalBox",
            "IfcAirToAirHeatRecovery",
            "IfcDamper",
            "IfcFan",
            "IfcBoiler",
            "IfcChiller",
            "IfcCoil",
            "IfcCompressor",
            "IfcCondenser",
            "IfcCooledBeam",
            "IfcCoolingTower",
            "IfcEvaporativeCooler",
            "IfcEvaporator",
            "IfcHeatExchanger",
            "IfcHumidifier",
            "IfcUnitaryEquipment",
            "IfcSpaceHeater",
            "IfcFilter",
            "IfcBurner",
            "IfcEngine",
            "IfcTubeBundle",
            "IfcMedicalDevice",
            "IfcTransportElement",
            "IfcGasTerminal",
        ],
        _M,
    ),
    # plumbing and fire protection
    **dict.fromkeys(
        [
            "IfcPipeSegment",
            "IfcPipeFitting",
            "IfcSanitaryTerminal",
            "IfcWasteTerminal",
            "IfcFireSuppressionTerminal",
            "IfcInterceptor",
            "IfcTank",
            "IfcPump",
            "IfcValve",
            "IfcStackTerminal",
            "IfcFlowMeter",
        ],
        _P,
    ),
    # electrical, lighting, communications, controls
    **dict.fromkeys(
        [
            "IfcCableSegment",
            "IfcCableFitting",
            "IfcCableCarrierSegment",
            "IfcCableCarrierFitting",
            "IfcLightFixture",
            "IfcLamp",
            "IfcElectricAppliance",
            "IfcOutlet",
            "IfcSwitchingDevice",
            "IfcProtectiveDevice",
            "IfcProtectiveDeviceTrippingUnit",
            "IfcElectricDistributionBoard",
            "IfcElectricDistributionPoint",
            "IfcElectricFlowStorageDevice",
            "IfcElectricGenerator",
            "IfcElectricMotor",
            "IfcElectricTimeControl",
            "IfcElectricHeater",
            "IfcJunctionBox",
            "IfcTransformer",
            "IfcMotorConnection",
            "IfcSolarDevice",
            "IfcAudioVisualAppliance",
            "IfcCommunicationsAppliance",
            "IfcElectricalElement",
            "IfcDistributionControlElement",
            "IfcController",
            "IfcSensor",
            "IfcActuator",
            "IfcAlarm",
            "IfcFlowInstrument",
            "IfcUnitaryControlElement",
        ],
        _E,
    ),
}

#: Generic distribution classes (all of IFC2X3's MEP occurrences) and their fallback.
GENERIC_DEFAULT: dict[str, str] = {
    "IfcFlowSegment": _M,
    "IfcFlowFitting": _M,
    "IfcFlowTerminal": _M,
    "IfcFlowController": _M,
    "IfcFlowMovingDevice": _M,
    "IfcFlowStorageDevice": _P,
    "IfcFlowTreatmentDevice": _M,
    "IfcEnergyConversionDevice": _M,
    "IfcDistributionFlowElement": _M,
    "IfcDistributionChamberElement": _P,
    "IfcDistributionElement": _M,
}

#: IFC4 ``IfcDistributionSystem.PredefinedType`` (and IFC2X3-era system names) → discipline.
SYSTEM_DISCIPLINE: dict[str, str] = {
    **dict.fromkeys(
        [
            "AIRCONDITIONING",
            "VENTILATION",
            "EXHAUST",
            "HEATING",
            "CHILLEDWATER",
            "CONDENSERWATER",
            "REFRIGERATION",
            "FUEL",
            "GAS",
            "OIL",
            "COMPRESSEDAIR",
            "VACUUM",
            "CONVEYING",
        ],
        _M,
    ),
    **dict.fromkeys(
        [
            "DOMESTICCOLDWATER",
            "DOMESTICHOTWATER",
            "DRAINAGE",
            "SEWAGE",
            "STORMWATER",
            "WASTEWATER",
            "WATERSUPPLY",
            "RAINWATER",
            "FIREPROTECTION",
            "SPRINKLER",
            "VENT",
        ],
        _P,
    ),
    **dict.fromkeys(
        [
            "ELECTRICAL",
            "LIGHTING",
            "LIGHTNINGPROTECTION",
            "POWERGENERATION",
            "EARTHING",
            "COMMUNICATION",
            "DATA",
            "SECURITY",
            "CONTROL",
            "TELEPHONE",
            "TV",
            "AUDIOVISUAL",
            "SIGNAL",
            "FIREALARM",
            "ELECTROACOUSTIC",
        ],
        _E,
    ),
}

#: Aggregates whose parts are architectural whatever their class.
ARCHITECTURAL_WHOLES: tuple[str, ...] = ("IfcWindow", "IfcDoor", "IfcCurtainWall", "IfcStair", "IfcRamp", "IfcRailing")
_WALL_SLAB = {"IfcWall": "Pset_WallCommon", "IfcSlab": "Pset_SlabCommon"}


@lru_cache(maxsize=4096)
def lineage(schema: str, ifc_class: str) -> tuple[str, ...]:
    """The class and its supertypes, most specific first: ('IfcWallStandardCase', 'IfcWall', ...); () if not in ``schema``."""
    try:
        decl = _wrapper.schema_by_name(schema).declaration_by_name(ifc_class)
    except (RuntimeError, IndexError, KeyError):
        return ()
    if not hasattr(decl, "supertype"):  # a type or enumeration, not an entity
        return ()
    names = []
    while decl is not None:
        names.append(decl.name())
        decl = decl.supertype()
    return tuple(names)


def _class_lookup(schema: str, ifc_class: str, table: dict[str, str]) -> tuple[str, str] | None:
    """(matched class, discipline) of the nearest ancestor of ``ifc_class`` in ``table``."""
    for name in lineage(schema, ifc_class):
        if name in table:
            return name, table[name]
    return None


def _from_type(element: ifcopenshell.entity_instance, schema: str) -> str | None:
    type_obj = _uel.get_type(element)
    if type_obj is None:
        return None
    name = type_obj.is_a()
    for suffix in ("Type", "Style"):
        if name.endswith(suffix):
            name = name[: -len(suffix)]
            break
    hit = _class_lookup(schema, name, CLASS_DISCIPLINE)
    return hit[1] if hit else CLASS_DISCIPLINE.get(name)


def _from_system(element: ifcopenshell.entity_instance) -> str | None:
    for rel in getattr(element, "HasAssignments", None) or ():
        if not rel.is_a("IfcRelAssignsToGroup"):
            continue
        group = rel.RelatingGroup
        if not group.is_a("IfcSystem"):
            continue
        predefined = getattr(group, "PredefinedType", None)
        if predefined and predefined in SYSTEM_DISCIPLINE:
            return SYSTEM_DISCIPLINE[predefined]
    return None


def _load_bearing(element: ifcopenshell.entity_instance, pset: str) -> bool:
    value = _uel.get_pset(element, pset, "LoadBearing")
    return value is True


def discipline_of(element: ifcopenshell.entity_instance, schema: str, _depth: int = 0) -> str:
    """'S', 'A', 'M', 'P', 'E' or '' (unclassified) for one IFC product of a file in ``schema`` ('IFC2X3', 'IFC4', ...).

    See the module docstring for the rule.
    """
    ifc_class = element.is_a()
    chain = lineage(schema, ifc_class) or (ifc_class,)
    whole = _uel.get_aggregate(element)
    if whole is not None and whole.is_a("IfcElement"):
        if any(n in ARCHITECTURAL_WHOLES for n in lineage(schema, whole.is_a())):
            return _A
        if "IfcBuildingElementPart" in chain and _depth < 8:
            return discipline_of(whole, schema, _depth + 1)
    if "IfcBuildingElementPart" in chain:
        return _A
    for base, pset in _WALL_SLAB.items():
        if base in chain:
            if base == "IfcSlab" and getattr(element, "PredefinedType", None) == "BASESLAB":
                return _S
            return _S if _load_bearing(element, pset) else _A
    specific = _class_lookup(schema, ifc_class, CLASS_DISCIPLINE)
    generic = _class_lookup(schema, ifc_class, GENERIC_DEFAULT)
    if specific is not None and (generic is None or chain.index(specific[0]) < chain.index(generic[0])):
        return specific[1]
    if generic is not None:
        return _from_type(element, schema) or _from_system(element) or generic[1]
    return ""
