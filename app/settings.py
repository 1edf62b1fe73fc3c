"""All settings in one place (pydantic-settings). Environment variables use the prefix HUMANOID_, except the
conventional DATABASE_URL, HOST and PORT, which are read as they are."""

from __future__ import annotations

from dataclasses import replace
from functools import lru_cache
from pathlib import Path
from typing import Literal

from pydantic import AliasChoices, Field
from pydantic_settings import BaseSettings, SettingsConfigDict

from app.web.tls import TlsFiles
from robot.diagnostics.thresholds import Thresholds
from robot.hardware.config import HardwareConfig, default_config, load_config
from robot.planning.config import PlannerConfig
from robot.speech.robot_voice import VoiceConfig

REPO_ROOT = Path(__file__).resolve().parents[1]


class Settings(BaseSettings):
    model_config = SettingsConfigDict(
        env_prefix="HUMANOID_", env_file=".env", extra="ignore", env_nested_delimiter="__"
    )

    host: str = Field("127.0.0.1", validation_alias=AliasChoices("HOST", "HUMANOID_HOST"))
    port: int = Field(8000, ge=1, le=65535, validation_alias=AliasChoices("PORT", "HUMANOID_PORT"))
    database_url: str = Field(
        f"sqlite:///{REPO_ROOT / 'data' / 'humanoid.db'}",
        validation_alias=AliasChoices("DATABASE_URL", "HUMANOID_DATABASE_URL"),
    )
    viser_port: int = Field(8081, ge=1, le=65535, description="port of the 3D view for browsers with a GPU")
    viser_light_port: int = Field(8082, ge=1, le=65535, description="port of the light 3D view (software WebGL)")
    viser_host: str = Field(
        "",
        description="interface the 3D views' gates listen on (empty: the app's own HOST); viser itself stays on "
        "loopback",
    )
    tls_cert: str = Field("", description="HTTPS: the certificate (PEM) the server and the 3D views present")
    tls_key: str = Field("", description="HTTPS: its private key (PEM)")
    backend: Literal["sim", "dynamixel"] = Field("sim", description="sim (MuJoCo) or dynamixel (the real robot)")
    robot_config: str = Field(str(REPO_ROOT / "robot.toml"), description="the real robot's servos (see README)")
    auth: Literal["auto", "on", "off"] = Field(
        "auto", description="access control: auto (on once a user exists), on, or off (only on a loopback address)"
    )
    allowed_origins: list[str] = Field(
        default_factory=list, description="other origins whose pages may use the API and WebSocket (CORS-like)"
    )
    deadman_s: float = Field(
        1.5,
        ge=0,
        le=10,
        description="real robot: torque off (after the controlled stop) when no operator page or "
        "script has sent a heartbeat for this long; 0 turns the deadman off",
    )
    dynamixel_port: str = Field("", description="the U2D2's serial device; overrides the robot configuration's")
    imu: str = Field("", description="real robot's IMU: opencr, bno055:<serial port> or none (empty: robot.toml's)")
    feet: str = Field("", description="real robot's foot sensors: fsr or none (empty: robot.toml's)")
    camera: str = Field(
        "",
        description="real robot's head camera: a device index, path or URL, realsense, or none (empty: robot.toml's)",
    )
    lidar: str = Field("", description="real robot's lidar: ld06:<serial port>, ld19:<serial port> or none")
    seed: int = Field(0, ge=0)
    control_hz: float = Field(100.0, gt=0, le=1000)
    mirror_hz: float = Field(30.0, gt=0, le=120)
    ws_state_hz: float = Field(20.0, gt=0, le=100, description="state pushes per second to each browser")
    max_body_bytes: int = Field(64 * 1024, gt=0, description="largest accepted HTTP request body")
    enable_mirror: bool = True
    mirror_software_dpr: float = Field(
        0.5, gt=0, le=2, description="3D view resolution scale in browsers that render WebGL in software"
    )
    mirror_shadows: bool = Field(False, description="shadows in the 3D view (costly where WebGL runs in software)")
    worker_process: bool = Field(True, description="run the robot worker in its own process (keeps its loop on time)")
    supervise_worker: bool = Field(
        True, description="restart a robot process that dies (e-stop latched, a new session); 3 times in 5 min at most"
    )
    perception: bool = Field(True, description="head camera, detection, lidar and map (about 25 % of one core)")
    camera_stream_width: int = Field(
        320,
        ge=0,
        le=1920,
        description="camera frames sent to pages are scaled to this width (the page draws them "
        "320 px wide; a remote viewer's bandwidth); 0: as the camera takes them",
    )

    # planning: which planner turns commands into plans, and how the executor recovers
    planner_backend: Literal["rules", "openai", "local"] = Field(
        "rules", description="rules (built in, offline), openai (any OpenAI-compatible server) or local (a GGUF file)"
    )
    openai_base_url: str = Field("http://127.0.0.1:8080/v1", description="e.g. https://api.groq.com/openai/v1")
    openai_api_key: str = Field("", validation_alias=AliasChoices("HUMANOID_OPENAI_API_KEY", "OPENAI_API_KEY"))
    openai_model: str = "llama-3.3-70b-versatile"
    openai_timeout_s: float = Field(20.0, gt=0, le=300)
    openai_response_format: Literal["auto", "json_schema", "json_object", "none"] = Field(
        "auto", description="how to ask for JSON: auto tries json_schema, then json_object (llama.cpp), then none"
    )
    local_model_path: str = Field("", description="GGUF model file for the local backend (pip install .[local-llm])")
    local_threads: int | None = Field(None, ge=1, le=256)
    local_timeout_s: float = Field(20.0, gt=0, le=300, description="longest a local model may take for a reply")
    local_chat_format: str = Field(
        "",
        description="chat format of a GGUF without a chat template (llama-cpp-python's names: gemma, chatml, "
        "...); empty chooses one from the model's family",
    )
    planner_max_repairs: int = Field(1, ge=0, le=5, description="re-asks of an LLM whose plan is invalid")
    planner_fallback: bool = Field(True, description="plan with rules when the LLM backend fails")
    max_auto_replans: int = Field(2, ge=0, le=10, description="automatic replans of a command after failed steps")
    approve_plans: bool = Field(False, description="plans wait for the operator's approval before they run")

    # speech
    asr_engine: Literal["auto", "pocketsphinx", "whisper"] = Field(
        "auto", description="speech recogniser: auto (whisper when installed, else pocketsphinx), pocketsphinx, whisper"
    )
    whisper_model_dir: str = Field(
        "", description="a faster-whisper (CTranslate2) model directory (empty: the one the whisper extra installs)"
    )
    whisper_second_model: str = Field(
        "auto",
        description="a second whisper model that hears again what the first is not sure of: auto (the base model "
        "the whisper extra installs), off, or a CTranslate2 model directory",
    )
    spoken_stop: bool = Field(True, description='a spoken "stop", "halt" or "freeze" latches the e-stop')
    asr_timeout_s: float = Field(
        15.0, gt=0, le=120, description="the page's recordings: a recogniser that takes longer is stopped (503)"
    )
    audio_dir: str = Field(str(REPO_ROOT / "data" / "audio"), description="where recordings are kept, by session")
    microphone: str = Field("auto", description='the robot\'s microphone: "auto" (default input), "off", or a name')
    speaker: str = Field("auto", description='the robot\'s speaker: "auto" (default output), "off", or a name')
    voice_auto_run: bool = Field(True, description="run what the robot's microphone hears when the recogniser is sure")

    # sessions: what is recorded, how long it is kept, the replay's 3D view
    record_camera_hz: float = Field(1.0, ge=0, le=30, description="head camera frames stored per second (0: none)")
    record_camera_width: int = Field(320, ge=32, le=1920, description="stored camera frames are scaled to this width")
    foxglove_port: int | None = Field(
        None,
        ge=0,
        le=65535,
        description="loopback port of the live Foxglove "
        "WebSocket server (off when unset; reached from elsewhere at /foxglove)",
    )
    record_scan_hz: float = Field(2.0, ge=0, le=10, description="lidar scans stored per second (0: none)")
    record_map_period_s: float = Field(2.0, ge=0, description="store the map when it changed, this often at most (s)")
    session_retention_days: float = Field(0.0, ge=0, description="delete sessions older than this (0: keep all)")
    session_retention_count: int = Field(0, ge=0, description="keep at most this many sessions (0: no limit)")
    replay_port: int = Field(8083, ge=1, le=65535, description="port of the session replay's 3D view")
    max_import_bytes: int = Field(512 * 1024 * 1024, gt=0, description="largest session JSON accepted for import")

    # diagnostics: where OK ends (each field of robot.diagnostics.thresholds.Thresholds, e.g.
    # HUMANOID_DIAGNOSTICS__SERVO_TEMPERATURE_ERROR_C=70)
    diagnostics: Thresholds = Field(default_factory=Thresholds)

    @property
    def data_dir(self) -> str:
        """Where recordings (and, with SQLite, the database) are kept: the disk diagnostics watch."""
        return str(Path(self.audio_dir).parent)

    def scene_host(self) -> str:
        """Where the 3D views' gates listen: where the app does, unless told otherwise."""
        return self.viser_host or self.host

    def tls_files(self) -> TlsFiles | None:
        return TlsFiles(self.tls_cert, self.tls_key) if self.tls_cert and self.tls_key else None

    def voice_config(self) -> VoiceConfig:
        """The robot's microphone and speaker; its recordings wait under the audio directory for the session."""
        return VoiceConfig(
            microphone=self.microphone,
            speaker=self.speaker,
            engine=self.asr_engine,
            whisper_model_dir=self.whisper_model_dir,
            whisper_second_model=self.whisper_second_model,
            auto_run=self.voice_auto_run,
            spoken_stop=self.spoken_stop,
            spool_dir=str(Path(self.audio_dir) / "incoming"),
        )

    def hardware_config(self) -> HardwareConfig:
        """The robot configuration file (the humanoid_v1 defaults when there is none yet), with the port set here."""
        path = Path(self.robot_config)
        config = load_config(path) if path.exists() else default_config()
        overrides = {
            "port": self.dynamixel_port,
            "imu": self.imu,
            "feet": self.feet,
            "camera": self.camera,
            "lidar": self.lidar,
        }
        return replace(config, **{key: value for key, value in overrides.items() if value})

    def planner_config(self) -> PlannerConfig:
        return PlannerConfig(
            backend=self.planner_backend,
            openai_base_url=self.openai_base_url,
            openai_api_key=self.openai_api_key,
            openai_model=self.openai_model,
            openai_timeout_s=self.openai_timeout_s,
            openai_response_format=self.openai_response_format,
            local_model_path=self.local_model_path,
            local_threads=self.local_threads,
            local_timeout_s=self.local_timeout_s,
            local_chat_format=self.local_chat_format,
            max_repairs=self.planner_max_repairs,
            fallback_to_rules=self.planner_fallback,
        )


@lru_cache
def get_settings() -> Settings:
    return Settings()
