"""Type hints of opentmcl's native module (PyO3)."""

import os
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

__version__: str

Instruction = Tuple[int, int, int, int]
WorldSpec = Union[str, "os.PathLike[str]"]
ProgramLike = Union["Program", bytes, Sequence[Instruction]]

class TmclError(Exception):
    """A module refused a request; ``status`` is the TMCL reply status."""
    status: int

class AssemblyError(ValueError):
    """Source that does not assemble: the first error's place and every diagnostic."""
    file: str
    line: int
    column: int
    message: str
    diagnostics: List["Diagnostic"]

class Diagnostic:
    file: str
    line: int
    column: int
    width: int
    message: str
    source_line: str

class Reply:
    status: Optional[int]
    value: Optional[int]
    opcode: int
    raw: List[int]
    @property
    def ok(self) -> bool: ...
    @property
    def status_text(self) -> str: ...
    def __bytes__(self) -> bytes: ...

class World:
    def load(self, world: WorldSpec) -> None: ...
    @property
    def shaft(self) -> int: ...
    @property
    def commanded(self) -> int: ...
    @property
    def lost_full_steps(self) -> int: ...
    @property
    def position(self) -> float: ...
    @property
    def load_torque(self) -> float: ...
    @property
    def coil_current(self) -> float: ...
    @property
    def supply_voltage(self) -> float: ...
    @property
    def outputs(self) -> int: ...
    # Run-time changes (docs/world.md, "Changing the world at run time"): each is a change the firmware
    # notices at once, as a world file's timeline entry at that instant.
    @property
    def left(self) -> bool:
        """The left stop switch pressed now; set True/False to press/hold released, None to follow the position."""
    @left.setter
    def left(self, pressed: Optional[bool]) -> None: ...
    @property
    def right(self) -> bool:
        """The right stop switch pressed now; set as `left`."""
    @right.setter
    def right(self, pressed: Optional[bool]) -> None: ...
    @property
    def home(self) -> bool:
        """The home switch pressed now; set as `left`."""
    @home.setter
    def home(self, pressed: Optional[bool]) -> None: ...
    @property
    def seized(self) -> bool:
        """The shaft seized now; set True to seize it where it is, False to free it."""
    @seized.setter
    def seized(self, seized: bool) -> None: ...
    @property
    def friction(self) -> float:
        """Coulomb friction on the shaft in N·m (>= 0)."""
    @friction.setter
    def friction(self, friction: float) -> None: ...
    @property
    def external_torque(self) -> float:
        """External torque on the shaft in N·m, positive pushes toward + (the world file's load.script)."""
    @external_torque.setter
    def external_torque(self, torque: float) -> None: ...
    @property
    def inputs(self) -> int:
        """Digital inputs, bit n = INn."""
    @inputs.setter
    def inputs(self, bits: int) -> None: ...
    @property
    def analog(self) -> int:
        """Analog input 0, 0..4095."""
    @analog.setter
    def analog(self, value: int) -> None: ...
    @property
    def temperature(self) -> int:
        """Module temperature in °C."""
    @temperature.setter
    def temperature(self, celsius: int) -> None: ...
    def slip_encoder(self, counts: int) -> None:
        """The encoder gains `counts` counts now (negative: loses them)."""

class Module:
    def __init__(
        self,
        model: str = "pd28-1021",
        world: Optional[WorldSpec] = None,
        eeprom: Optional[Union[str, "os.PathLike[str]"]] = None,
        address: int = 1,
        link: Union[bool, str, "os.PathLike[str]", None] = None,
        tcp: Union[bool, str, None] = None,
        wire_timing: bool = False,
        interface: Optional[str] = None,
    ) -> None: ...
    @staticmethod
    def bus(
        modules: Sequence[Union[str, Dict[str, Any]]],
        link: Union[bool, str, "os.PathLike[str]", None] = None,
        tcp: Union[bool, str, None] = None,
        wire_timing: bool = False,
        interface: Optional[str] = None,
    ) -> List["Module"]: ...
    @property
    def link(self) -> Optional[str]: ...
    @property
    def tcp_address(self) -> Optional[str]: ...
    @property
    def model(self) -> str: ...
    @property
    def name(self) -> str: ...
    @property
    def address(self) -> int: ...
    @property
    def eeprom(self) -> Optional[str]: ...
    @property
    def time(self) -> float: ...
    @property
    def world(self) -> World: ...
    @property
    def closed(self) -> bool: ...
    def request(self, command: Union[str, int], type: int = 0, motor: int = 0, value: int = 0) -> Reply: ...
    def get(self, name: str, motor: int = 0) -> int: ...
    def set(self, name: str, value: int, motor: int = 0) -> None: ...
    def store(self, name: str, motor: int = 0) -> None: ...
    def load_program(self, program: ProgramLike, start: bool = False) -> None: ...
    def close(self) -> None: ...
    def __enter__(self) -> "Module": ...
    def __exit__(self, *exc: Any) -> bool: ...

class Program:
    @staticmethod
    def from_bin(image: bytes) -> "Program": ...
    @property
    def instructions(self) -> List[Instruction]: ...
    @property
    def labels(self) -> Dict[str, int]: ...
    @property
    def constants(self) -> Dict[str, int]: ...
    @property
    def lines(self) -> List[Tuple[str, int]]: ...
    def to_bin(self) -> bytes: ...
    def disassemble(self, addresses: bool = False) -> str: ...
    def __len__(self) -> int: ...

def assemble(
    source: Union[str, "os.PathLike[str]"],
    model: str = "pd28-1021",
    include_dirs: Sequence[Union[str, "os.PathLike[str]"]] = (),
    name: str = "<source>",
) -> Program: ...
def disassemble(program: ProgramLike, addresses: bool = False) -> str: ...
def models() -> List[Tuple[str, str]]: ...
def run(
    program: Union[str, ProgramLike],
    seconds: float = 3600.0,
    world: Optional[WorldSpec] = None,
    every: float = 0.01,
    model: str = "pd28-1021",
    settings: Sequence[str] = (),
    drive: bool = False,
) -> Dict[str, Any]: ...
