"""The demo car catalog: twelve car models with published dimensions and a parametric body each.

Overall length, width (without mirrors), height and wheelbase are published manufacturer figures; for
the ten models of the paper's Table 1, length, width and height are exactly the table's. Tracks are
published figures rounded to the nearest 5 mm where sources differ by generation or trim. Body
proportions (bonnet, windscreen, roof, boot lengths, heights) and details are set by eye from side
and front photographs of each model, so that each rendered body reads as that car.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache

from vehloc.data.attributes import ModelAttributes
from vehloc.data.specs import VehicleSpec

RGB = tuple[int, int, int]

BODY_TYPE_CODES: dict[str, int] = {
    "mpv": 1,
    "suv": 2,
    "sedan": 3,
    "hatchback": 4,
    "fastback": 6,
    "pickup": 8,
    "sports": 9,
}
"""CompCars `attributes.txt` type code of each body type."""

GRILLES = ("kidney", "upright", "wide_bars", "chevron", "intake", "wing", "oval", "volvo", "slot", "big_bars")
HEADLIGHTS = ("twin_round", "angular", "round", "slit", "drop", "rect")
TAILLIGHTS = (
    "lbar", "wrap", "trapezoid", "vertical", "slit", "full_width", "round", "chrome_bar", "boomerang", "chevron_bar"
)


@dataclass(frozen=True)
class BodyShape:
    """Side profile and plan of the body (mm). Lengths run from the front end rearwards.

    The top outline goes: nose (front face top) -> bonnet rising to the cowl at the windscreen base ->
    windscreen -> roof -> rear window down to the deck -> boot (or bed) down to the tail (rear face
    top). The beltline runs from the cowl to the deck; the greenhouse above it narrows by
    ``tumblehome`` (roof half-width / shoulder half-width).
    """

    front_overhang_mm: float
    ground_clearance_mm: float
    wheel_radius_mm: float
    tyre_width_mm: float
    nose_height_mm: float
    cowl_height_mm: float
    bonnet_length_mm: float
    windscreen_run_mm: float
    roof_length_mm: float
    rear_window_run_mm: float
    deck_height_mm: float
    tail_height_mm: float
    tumblehome: float
    nose_width_frac: float
    tail_width_frac: float
    corner_length_mm: float = 450.0
    cargo_bed: bool = False


@dataclass(frozen=True)
class Details:
    """The details that tell similar bodies apart.

    ``window_splits``: positions of the pillars between side windows, as fractions of the side glass
    length from its front end (one window per side when empty). ``pillar``: "body" or "black".
    """

    grille: str
    grille_rgb: RGB
    headlight: str
    taillight: str
    window_splits: tuple[float, ...]
    pillar: str
    hub_rgb: RGB
    hub_spokes: int
    lower_cladding: bool = False

    @property
    def side_windows(self) -> int:
        return len(self.window_splits) + 1


@dataclass(frozen=True)
class CarModel:
    """One car model of the catalog (dimensions in mm)."""

    model_id: int
    make_id: int
    make: str
    model: str
    year: int
    body_type: str
    length_mm: float
    width_mm: float
    height_mm: float
    wheelbase_mm: float
    track_front_mm: float
    track_rear_mm: float
    shape: BodyShape
    details: Details
    palette: tuple[tuple[str, RGB], ...]
    maximum_speed_kmh: float
    displacement_l: float
    door_number: int
    seat_number: int

    @property
    def name(self) -> str:
        return f"{self.make} {self.model}"

    @property
    def rear_overhang_mm(self) -> float:
        return self.length_mm - self.wheelbase_mm - self.shape.front_overhang_mm

    @property
    def front_axle_x_mm(self) -> float:
        """Front axle position in the car frame (origin at the footprint centre, +x forward)."""
        return self.length_mm / 2 - self.shape.front_overhang_mm

    @property
    def rear_axle_x_mm(self) -> float:
        return self.front_axle_x_mm - self.wheelbase_mm

    @property
    def boot_length_mm(self) -> float:
        s = self.shape
        return (
            self.length_mm
            - s.bonnet_length_mm
            - s.windscreen_run_mm
            - s.roof_length_mm
            - s.rear_window_run_mm
        )

    @property
    def cabin_front_x_mm(self) -> float:
        """Windscreen base (start of the beltline), car frame."""
        return self.length_mm / 2 - self.shape.bonnet_length_mm

    @property
    def cabin_rear_x_mm(self) -> float:
        """Rear window base (end of the beltline), car frame."""
        return -self.length_mm / 2 + self.boot_length_mm

    @property
    def type_code(self) -> int:
        return BODY_TYPE_CODES[self.body_type]


CATALOG: tuple[CarModel, ...] = (
    # BMW 7 Series F02 (750Li, 2013): wheelbase 3210 mm; tracks 1610/1650 mm.
    CarModel(
        model_id=1, make_id=1, make="BMW", model="7 Series", year=2013,
        body_type="sedan", length_mm=5250, width_mm=1902, height_mm=1498,
        wheelbase_mm=3210, track_front_mm=1610, track_rear_mm=1650,
        shape=BodyShape(
            front_overhang_mm=900, ground_clearance_mm=140, wheel_radius_mm=352, tyre_width_mm=245,
            nose_height_mm=760, cowl_height_mm=1000, bonnet_length_mm=1600, windscreen_run_mm=760,
            roof_length_mm=1500, rear_window_run_mm=650, deck_height_mm=1070, tail_height_mm=1020,
            tumblehome=0.78, nose_width_frac=0.86, tail_width_frac=0.9,
        ),
        details=Details(
            grille="kidney", grille_rgb=(25, 25, 28), headlight="twin_round", taillight="lbar",
            window_splits=(0.44, 0.82), pillar="black", hub_rgb=(190, 192, 196), hub_spokes=5,
        ),
        palette=(
            ("black", (18, 19, 22)), ("white", (234, 234, 230)), ("silver", (178, 181, 185)),
            ("imperial blue", (30, 40, 80)), ("space grey", (92, 94, 98)),
        ),
        maximum_speed_kmh=250, displacement_l=4.4, door_number=4, seat_number=5,
    ),
    # Mercedes-Benz R-Class W251 long (R 350 L, 2014): wheelbase 3215 mm; tracks 1640/1655 mm.
    CarModel(
        model_id=2, make_id=2, make="Mercedes-Benz", model="R Series", year=2014,
        body_type="mpv", length_mm=5159, width_mm=1922, height_mm=1663,
        wheelbase_mm=3215, track_front_mm=1640, track_rear_mm=1655,
        shape=BodyShape(
            front_overhang_mm=880, ground_clearance_mm=160, wheel_radius_mm=368, tyre_width_mm=255,
            nose_height_mm=820, cowl_height_mm=1080, bonnet_length_mm=1250, windscreen_run_mm=820,
            roof_length_mm=2500, rear_window_run_mm=380, deck_height_mm=1150, tail_height_mm=1100,
            tumblehome=0.8, nose_width_frac=0.86, tail_width_frac=0.9,
        ),
        details=Details(
            grille="wide_bars", grille_rgb=(30, 30, 32), headlight="angular", taillight="wrap",
            window_splits=(0.34, 0.7), pillar="black", hub_rgb=(200, 200, 204), hub_spokes=10,
        ),
        palette=(
            ("black", (18, 19, 22)), ("white", (234, 234, 230)), ("silver", (178, 181, 185)),
            ("tenorite grey", (100, 102, 104)), ("cavansite blue", (38, 52, 82)),
        ),
        maximum_speed_kmh=230, displacement_l=3.5, door_number=5, seat_number=6,
    ),
    # Mercedes-Benz S-Class W222 long (S 500 L, 2014): wheelbase 3165 mm; tracks 1625/1635 mm.
    CarModel(
        model_id=3, make_id=2, make="Mercedes-Benz", model="S Series", year=2014,
        body_type="sedan", length_mm=5250, width_mm=1899, height_mm=1494,
        wheelbase_mm=3165, track_front_mm=1625, track_rear_mm=1635,
        shape=BodyShape(
            front_overhang_mm=930, ground_clearance_mm=130, wheel_radius_mm=351, tyre_width_mm=245,
            nose_height_mm=740, cowl_height_mm=990, bonnet_length_mm=1550, windscreen_run_mm=800,
            roof_length_mm=1400, rear_window_run_mm=760, deck_height_mm=1050, tail_height_mm=1010,
            tumblehome=0.76, nose_width_frac=0.84, tail_width_frac=0.88,
        ),
        details=Details(
            grille="upright", grille_rgb=(45, 45, 48), headlight="angular", taillight="trapezoid",
            window_splits=(0.47, 0.86), pillar="body", hub_rgb=(205, 206, 210), hub_spokes=10,
        ),
        palette=(
            ("black", (18, 19, 22)), ("white", (234, 234, 230)), ("silver", (178, 181, 185)),
            ("palladium silver", (150, 152, 150)), ("anthracite blue", (40, 48, 64)),
        ),
        maximum_speed_kmh=250, displacement_l=4.7, door_number=4, seat_number=5,
    ),
    # BMW X5 F15 (xDrive35i, 2014): wheelbase 2933 mm; tracks 1645/1650 mm.
    CarModel(
        model_id=4, make_id=1, make="BMW", model="X5", year=2014,
        body_type="suv", length_mm=4909, width_mm=1938, height_mm=1772,
        wheelbase_mm=2933, track_front_mm=1645, track_rear_mm=1650,
        shape=BodyShape(
            front_overhang_mm=890, ground_clearance_mm=209, wheel_radius_mm=369, tyre_width_mm=255,
            nose_height_mm=900, cowl_height_mm=1180, bonnet_length_mm=1350, windscreen_run_mm=700,
            roof_length_mm=2150, rear_window_run_mm=420, deck_height_mm=1250, tail_height_mm=1200,
            tumblehome=0.8, nose_width_frac=0.86, tail_width_frac=0.9,
        ),
        details=Details(
            grille="kidney", grille_rgb=(25, 25, 28), headlight="twin_round", taillight="lbar",
            window_splits=(0.4, 0.78), pillar="black", hub_rgb=(170, 172, 176), hub_spokes=5,
            lower_cladding=True,
        ),
        palette=(
            ("black", (18, 19, 22)), ("white", (234, 234, 230)), ("silver", (178, 181, 185)),
            ("sparkling brown", (90, 60, 45)), ("melbourne red", (130, 20, 25)),
        ),
        maximum_speed_kmh=235, displacement_l=3.0, door_number=5, seat_number=5,
    ),
    # Citroen C4L (China, 2013): wheelbase 2710 mm; tracks 1530/1530 mm.
    CarModel(
        model_id=5, make_id=3, make="Citroen", model="C4L", year=2013,
        body_type="sedan", length_mm=4675, width_mm=1780, height_mm=1500,
        wheelbase_mm=2710, track_front_mm=1530, track_rear_mm=1530,
        shape=BodyShape(
            front_overhang_mm=910, ground_clearance_mm=140, wheel_radius_mm=334, tyre_width_mm=215,
            nose_height_mm=740, cowl_height_mm=960, bonnet_length_mm=1200, windscreen_run_mm=820,
            roof_length_mm=1250, rear_window_run_mm=720, deck_height_mm=1030, tail_height_mm=990,
            tumblehome=0.76, nose_width_frac=0.84, tail_width_frac=0.88,
        ),
        details=Details(
            grille="chevron", grille_rgb=(30, 30, 34), headlight="angular", taillight="chevron_bar",
            window_splits=(0.5, 0.88), pillar="black", hub_rgb=(175, 178, 182), hub_spokes=6,
        ),
        palette=(
            ("black", (18, 19, 22)), ("white", (234, 234, 230)), ("silver", (178, 181, 185)),
            ("shark grey", (90, 92, 95)), ("hazel brown", (120, 95, 70)), ("blue", (35, 65, 120)),
        ),
        maximum_speed_kmh=200, displacement_l=1.6, door_number=4, seat_number=5,
    ),
    # Lamborghini Gallardo LP 560-4 (2012): wheelbase 2560 mm; tracks 1620/1595 mm.
    CarModel(
        model_id=6, make_id=4, make="Lamborghini", model="Gallardo", year=2012,
        body_type="sports", length_mm=4345, width_mm=1900, height_mm=1165,
        wheelbase_mm=2560, track_front_mm=1620, track_rear_mm=1595,
        shape=BodyShape(
            front_overhang_mm=830, ground_clearance_mm=115, wheel_radius_mm=328, tyre_width_mm=265,
            nose_height_mm=600, cowl_height_mm=880, bonnet_length_mm=1300, windscreen_run_mm=780,
            roof_length_mm=650, rear_window_run_mm=1150, deck_height_mm=990, tail_height_mm=950,
            tumblehome=0.7, nose_width_frac=0.8, tail_width_frac=0.92,
        ),
        details=Details(
            grille="intake", grille_rgb=(20, 20, 22), headlight="slit", taillight="slit", window_splits=(),
            pillar="body", hub_rgb=(60, 62, 66), hub_spokes=5,
        ),
        palette=(
            ("giallo midas", (245, 190, 20)), ("arancio borealis", (240, 100, 20)),
            ("verde ithaca", (100, 170, 40)), ("bianco monocerus", (240, 240, 240)),
            ("nero noctis", (15, 15, 15)),
        ),
        maximum_speed_kmh=325, displacement_l=5.2, door_number=2, seat_number=2,
    ),
    # Hyundai Elantra XD (Beijing Hyundai, 2011): wheelbase 2610 mm; tracks 1485/1480 mm.
    CarModel(
        model_id=7, make_id=5, make="Hyundai", model="Elantra", year=2011,
        body_type="sedan", length_mm=4545, width_mm=1725, height_mm=1425,
        wheelbase_mm=2610, track_front_mm=1485, track_rear_mm=1480,
        shape=BodyShape(
            front_overhang_mm=900, ground_clearance_mm=150, wheel_radius_mm=307, tyre_width_mm=195,
            nose_height_mm=700, cowl_height_mm=930, bonnet_length_mm=1150, windscreen_run_mm=760,
            roof_length_mm=1250, rear_window_run_mm=640, deck_height_mm=990, tail_height_mm=960,
            tumblehome=0.76, nose_width_frac=0.86, tail_width_frac=0.9,
        ),
        details=Details(
            grille="oval", grille_rgb=(40, 40, 44), headlight="drop", taillight="boomerang",
            window_splits=(0.52,), pillar="black", hub_rgb=(165, 168, 170), hub_spokes=7,
        ),
        palette=(
            ("black", (18, 19, 22)), ("white", (234, 234, 230)), ("silver", (178, 181, 185)),
            ("red", (160, 25, 30)), ("champagne", (190, 170, 130)),
        ),
        maximum_speed_kmh=190, displacement_l=1.6, door_number=4, seat_number=5,
    ),
    # Porsche Panamera 971 (4S, 2017): wheelbase 2950 mm; tracks 1660/1650 mm.
    CarModel(
        model_id=8, make_id=6, make="Porsche", model="Panamera", year=2017,
        body_type="fastback", length_mm=5049, width_mm=1937, height_mm=1423,
        wheelbase_mm=2950, track_front_mm=1660, track_rear_mm=1650,
        shape=BodyShape(
            front_overhang_mm=960, ground_clearance_mm=140, wheel_radius_mm=373, tyre_width_mm=265,
            nose_height_mm=680, cowl_height_mm=940, bonnet_length_mm=1500, windscreen_run_mm=820,
            roof_length_mm=950, rear_window_run_mm=1350, deck_height_mm=1020, tail_height_mm=980,
            tumblehome=0.72, nose_width_frac=0.82, tail_width_frac=0.9,
        ),
        details=Details(
            grille="intake", grille_rgb=(22, 22, 24), headlight="drop", taillight="full_width",
            window_splits=(0.46, 0.84), pillar="black", hub_rgb=(120, 122, 126), hub_spokes=5,
        ),
        palette=(
            ("black", (18, 19, 22)), ("white", (234, 234, 230)), ("silver", (178, 181, 185)),
            ("mahogany", (75, 30, 25)), ("night blue", (25, 35, 60)), ("carmine red", (150, 15, 25)),
        ),
        maximum_speed_kmh=289, displacement_l=2.9, door_number=5, seat_number=4,
    ),
    # Honda Spirior (China, 2014): wheelbase 2775 mm; tracks 1590/1590 mm.
    CarModel(
        model_id=9, make_id=7, make="Honda", model="Spirior", year=2014,
        body_type="sedan", length_mm=4840, width_mm=1850, height_mm=1465,
        wheelbase_mm=2775, track_front_mm=1590, track_rear_mm=1590,
        shape=BodyShape(
            front_overhang_mm=960, ground_clearance_mm=140, wheel_radius_mm=334, tyre_width_mm=235,
            nose_height_mm=730, cowl_height_mm=980, bonnet_length_mm=1330, windscreen_run_mm=820,
            roof_length_mm=1300, rear_window_run_mm=730, deck_height_mm=1040, tail_height_mm=1000,
            tumblehome=0.75, nose_width_frac=0.85, tail_width_frac=0.89,
        ),
        details=Details(
            grille="wing", grille_rgb=(30, 30, 33), headlight="angular", taillight="chrome_bar",
            window_splits=(0.48, 0.85), pillar="black", hub_rgb=(185, 187, 190), hub_spokes=10,
        ),
        palette=(
            ("black", (18, 19, 22)), ("white", (234, 234, 230)), ("silver", (178, 181, 185)),
            ("dark blue", (30, 40, 70)), ("bronze", (110, 85, 60)),
        ),
        maximum_speed_kmh=210, displacement_l=2.4, door_number=4, seat_number=5,
    ),
    # Volvo C30 (2.0, 2010): wheelbase 2640 mm; tracks 1535/1530 mm.
    CarModel(
        model_id=10, make_id=8, make="Volvo", model="C30", year=2010,
        body_type="hatchback", length_mm=4266, width_mm=1782, height_mm=1447,
        wheelbase_mm=2640, track_front_mm=1535, track_rear_mm=1530,
        shape=BodyShape(
            front_overhang_mm=880, ground_clearance_mm=140, wheel_radius_mm=318, tyre_width_mm=205,
            nose_height_mm=730, cowl_height_mm=960, bonnet_length_mm=1150, windscreen_run_mm=780,
            roof_length_mm=1420, rear_window_run_mm=720, deck_height_mm=950, tail_height_mm=900,
            tumblehome=0.74, nose_width_frac=0.86, tail_width_frac=0.88,
        ),
        details=Details(
            grille="volvo", grille_rgb=(28, 28, 30), headlight="angular", taillight="vertical",
            window_splits=(0.62,), pillar="black", hub_rgb=(175, 178, 182), hub_spokes=5,
        ),
        palette=(
            ("passion red", (180, 20, 25)), ("orange flame", (220, 100, 30)), ("ice white", (236, 236, 232)),
            ("black", (18, 19, 22)), ("cosmic blue", (60, 90, 150)),
        ),
        maximum_speed_kmh=200, displacement_l=2.0, door_number=3, seat_number=4,
    ),
    # Fiat 500 (1.2, 2008): 3546 x 1627 x 1488 mm, wheelbase 2300 mm; tracks 1405/1395 mm.
    CarModel(
        model_id=11, make_id=9, make="Fiat", model="500", year=2008,
        body_type="hatchback", length_mm=3546, width_mm=1627, height_mm=1488,
        wheelbase_mm=2300, track_front_mm=1405, track_rear_mm=1395,
        shape=BodyShape(
            front_overhang_mm=600, ground_clearance_mm=130, wheel_radius_mm=292, tyre_width_mm=185,
            nose_height_mm=720, cowl_height_mm=930, bonnet_length_mm=780, windscreen_run_mm=640,
            roof_length_mm=1450, rear_window_run_mm=420, deck_height_mm=1000, tail_height_mm=960,
            tumblehome=0.74, nose_width_frac=0.84, tail_width_frac=0.88, corner_length_mm=380,
        ),
        details=Details(
            grille="slot", grille_rgb=(40, 40, 44), headlight="round", taillight="round",
            window_splits=(0.64,), pillar="body", hub_rgb=(200, 202, 205), hub_spokes=7,
        ),
        palette=(
            ("pasodoble red", (190, 25, 30)), ("bossa nova white", (240, 238, 230)),
            ("azzurro", (120, 170, 210)), ("black", (18, 19, 22)), ("cream", (235, 225, 190)),
            ("yellow", (240, 200, 50)),
        ),
        maximum_speed_kmh=160, displacement_l=1.2, door_number=3, seat_number=4,
    ),
    # Toyota Hilux double cab (AN120, 2.8 D-4D, 2016): 5330 x 1855 x 1815 mm, wheelbase 3085 mm;
    # tracks 1540/1550 mm; ground clearance 286 mm.
    CarModel(
        model_id=12, make_id=10, make="Toyota", model="Hilux", year=2016,
        body_type="pickup", length_mm=5330, width_mm=1855, height_mm=1815,
        wheelbase_mm=3085, track_front_mm=1540, track_rear_mm=1550,
        shape=BodyShape(
            front_overhang_mm=900, ground_clearance_mm=286, wheel_radius_mm=388, tyre_width_mm=265,
            nose_height_mm=1040, cowl_height_mm=1260, bonnet_length_mm=1250, windscreen_run_mm=650,
            roof_length_mm=1420, rear_window_run_mm=90, deck_height_mm=1300, tail_height_mm=1260,
            tumblehome=0.82, nose_width_frac=0.88, tail_width_frac=0.97, corner_length_mm=350,
            cargo_bed=True,
        ),
        details=Details(
            grille="big_bars", grille_rgb=(25, 25, 28), headlight="angular", taillight="vertical",
            window_splits=(0.52,), pillar="black", hub_rgb=(160, 162, 166), hub_spokes=6,
            lower_cladding=True,
        ),
        palette=(
            ("black", (18, 19, 22)), ("white", (234, 234, 230)), ("silver", (178, 181, 185)),
            ("grey", (100, 100, 100)), ("red", (150, 20, 20)), ("nebula blue", (30, 45, 80)),
        ),
        maximum_speed_kmh=175, displacement_l=2.8, door_number=4, seat_number=5,
    ),
)


def validate_model(model: CarModel) -> list[str]:
    """Inconsistencies of a model's parameters (empty when it can be built)."""
    s, d = model.shape, model.details
    problems = []
    if model.boot_length_mm < 0:
        problems.append(f"profile lengths exceed the overall length by {-model.boot_length_mm:.0f} mm")
    if not s.ground_clearance_mm < s.wheel_radius_mm < s.nose_height_mm:
        problems.append("need ground clearance < wheel radius < nose height")
    if not max(s.cowl_height_mm, s.deck_height_mm) < model.height_mm:
        problems.append("cowl and deck must be below the roof")
    if not s.nose_height_mm <= s.cowl_height_mm:
        problems.append("the bonnet must rise from nose to cowl")
    if not s.tail_height_mm <= s.deck_height_mm:
        problems.append("the boot must fall from deck to tail")
    arch_mm = s.wheel_radius_mm + 35
    if s.front_overhang_mm < arch_mm + 100 or model.rear_overhang_mm < arch_mm + 100:
        problems.append("overhangs too short for the wheel arches")
    bonnet_at_axle_mm = s.nose_height_mm + (s.cowl_height_mm - s.nose_height_mm) * min(
        1.0, s.front_overhang_mm / s.bonnet_length_mm
    )
    if min(bonnet_at_axle_mm, s.tail_height_mm) < s.wheel_radius_mm + arch_mm + 60:
        problems.append("wings over the wheel arches thinner than 60 mm")
    for track in (model.track_front_mm, model.track_rear_mm):
        if track / 2 + s.tyre_width_mm / 2 > model.width_mm / 2:
            problems.append(f"tyres on track {track} mm stick out of the body")
    if not 0 < s.tumblehome <= 1 or not 0 < s.nose_width_frac <= 1 or not 0 < s.tail_width_frac <= 1:
        problems.append("width fractions must be in (0, 1]")
    if list(d.window_splits) != sorted(d.window_splits) or any(not 0.15 < f < 0.95 for f in d.window_splits):
        problems.append("window splits must increase within (0.15, 0.95)")
    if d.grille not in GRILLES or d.headlight not in HEADLIGHTS or d.taillight not in TAILLIGHTS:
        problems.append("unknown grille, headlight or tail-light style")
    if d.pillar not in ("body", "black") or model.body_type not in BODY_TYPE_CODES or not model.palette:
        problems.append("unknown pillar style or body type, or empty palette")
    return problems


@cache
def model_by_id(model_id: int) -> CarModel:
    """The catalog model with this id."""
    for model in CATALOG:
        if model.model_id == model_id:
            return model
    raise KeyError(f"no catalog model with id {model_id}")


def make_names() -> list[str]:
    """Make names indexed by make id - 1."""
    names: dict[int, str] = {m.make_id: m.make for m in CATALOG}
    return [names[i] for i in range(1, max(names) + 1)]


def model_names() -> list[str]:
    """Model names (make and model) indexed by model id - 1."""
    names = {m.model_id: m.name for m in CATALOG}
    return [names[i] for i in range(1, max(names) + 1)]


def vehicle_specs() -> list[VehicleSpec]:
    """The specs table rows of the catalog."""
    return [
        VehicleSpec(m.model_id, m.make, m.name, m.length_mm, m.width_mm, m.height_mm, m.wheelbase_mm)
        for m in CATALOG
    ]


def model_attributes() -> list[ModelAttributes]:
    """The CompCars attributes rows of the catalog."""
    return [
        ModelAttributes(
            m.model_id, m.maximum_speed_kmh, m.displacement_l, m.door_number, m.seat_number, m.type_code
        )
        for m in CATALOG
    ]
